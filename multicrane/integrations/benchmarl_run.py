"""BenchMARL's Hydra command line, with every multicrane scenario registered as a task.

    python -m multicrane.integrations.benchmarl_run algorithm=mappo task=multicrane/e3s2 \\
        task.n_cranes=2 task.decisions=task task.max_cycles=100 experiment.max_n_frames=60000

Every argument is BenchMARL's own (``benchmarl/run.py``: ``algorithm=``, ``task=``,
``model=``, ``experiment.<key>=``, ``seed=``, ``-m`` for a sweep); the task keys are those of
``multicrane.integrations.benchmarl``. Needs the ``benchmarl`` extra.
"""

from __future__ import annotations

from multicrane.integrations.benchmarl import register


def main() -> None:
    """Register the tasks, then hand the command line to BenchMARL's Hydra entry point."""
    register()
    from benchmarl.run import hydra_experiment

    hydra_experiment()


if __name__ == "__main__":
    main()
