"""Milliseconds per ``reset`` of the task-level environment, public API only.

    PYTHONPATH=. python tools/task_reset_speed.py hall-4c 4 500
    git worktree add /tmp/wt 8e38701                        # an older tree
    PYTHONPATH=/tmp/wt python tools/task_reset_speed.py hall-4c 4 500

``multicrane.parallel_env(SCENARIO, n_cranes=CRANES, decisions="task")`` reset ``RESETS``
times with seeds 0, 1, ... after one warm-up reset (which builds the site's caches). A reset
draws the yard, builds the task book (every task's static path length per crane) and the
first observation; a training run pays it once per episode. Prints milliseconds per reset of
wall time and of CPU time (``time.process_time``, less sensitive to other jobs)
(docs/performance.md, "Task-mode resets").
"""

from __future__ import annotations

import sys
import time

import multicrane


def main(scenario: str, cranes: int, resets: int) -> None:
    env = multicrane.parallel_env(scenario, n_cranes=cranes, decisions="task")
    env.reset(seed=10**6)
    wall, cpu = time.perf_counter(), time.process_time()
    for seed in range(resets):
        env.reset(seed=seed)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    print(f"{scenario}, {cranes} cranes: {1000 * wall / resets:.3f} ms per reset (wall), "
          f"{1000 * cpu / resets:.3f} ms (CPU), {resets} resets")  # fmt: skip


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]), int(sys.argv[3]))
