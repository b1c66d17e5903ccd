"""Training throughput: environment steps per second of a learner, rollouts and updates.

``training_steps_per_second`` builds a learner as ``multicrane train`` does (its default
copies and settings, the paper mode) and times its ``learn`` over a number of steps:
collecting, updating and the environments' resets, not building it. ``multicrane bench
--train`` puts the lean PPO beside SB3's MaskablePPO with it (docs/training.md).
"""

from __future__ import annotations

import time

import torch as th

from multicrane.training.algorithms import algorithm, hyperparameters, make_model
from multicrane.training.config import TrainConfig
from multicrane.training.run_envs import make_vec_env


def training_steps_per_second(algo_name: str, config: str, steps: int, seed: int = 0,
                              n_envs: int | None = None) -> tuple[float, float]:  # fmt: skip
    """Steps per second of ``algo_name``'s ``learn(steps)`` on the paper ``config`` (one
    torch thread): its steps done (a whole last rollout) over the wall time, and over the
    process's CPU time (what an otherwise idle core would give, near enough, on a shared
    machine)."""
    th.set_num_threads(1)
    cfg = TrainConfig(config, paper=True, algo=algo_name, total_steps=steps, seed=seed,
                      n_envs=n_envs)  # fmt: skip
    algo = algorithm(algo_name, True)
    params = hyperparameters(algo, config, {})
    venv = make_vec_env(cfg, algo, params)
    model = make_model(algo, venv, seed, params, None)
    start, cpu = time.perf_counter(), time.process_time()
    model.learn(steps)
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    venv.close()
    return model.num_timesteps / wall, model.num_timesteps / cpu
