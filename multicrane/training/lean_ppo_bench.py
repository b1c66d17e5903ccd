"""Training throughput: environment steps per second of a learner, rollouts and updates.

``training_steps_per_second`` builds a learner as ``multicrane train`` does (its default
copies and settings; the paper mode, or the multi-agent motion mode with ``n_cranes``, where a
step is one crane's decision) and times its ``learn`` over a number of steps: collecting,
updating and the environments' resets, not building it. ``multicrane bench --train`` puts the
lean PPO beside SB3's MaskablePPO with it in both modes (docs/training.md).
"""

from __future__ import annotations

import time

import torch as th

from multicrane.training.algorithms import algorithm, hyperparameters, make_model
from multicrane.training.config import TrainConfig
from multicrane.training.run_envs import make_vec_env


def training_steps_per_second(algo_name: str, config: str, steps: int, seed: int = 0,
                              n_envs: int | None = None, n_cranes: int | None = None
                              ) -> tuple[float, float]:  # fmt: skip
    """Steps per second of ``algo_name``'s ``learn(steps)`` on the paper ``config``, or
    with ``n_cranes`` on the scenario ``config`` in the multi-agent motion mode (its default
    shaping; a step is a crane's decision), one torch thread: its steps done (a whole last
    rollout) over the wall time, and over the process's CPU time (what an otherwise idle
    core would give, near enough, on a shared machine)."""
    th.set_num_threads(1)
    paper = n_cranes is None
    cfg = TrainConfig(config, paper=paper, algo=algo_name, total_steps=steps, seed=seed,
                      n_envs=n_envs, n_cranes=n_cranes)  # fmt: skip
    algo = algorithm(algo_name, paper)
    params = hyperparameters(algo, cfg.scenario if paper else None, {})
    venv = make_vec_env(cfg, algo, params)
    model = make_model(algo, venv, seed, params, None)
    start, cpu = time.perf_counter(), time.process_time()
    model.learn(steps)
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    venv.close()
    return model.num_timesteps / wall, model.num_timesteps / cpu
