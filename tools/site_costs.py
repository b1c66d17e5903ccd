"""Costs of one site: load, environment, reset, joint step (random legal actions), planner calls.

    PYTHONPATH=. python tools/site_costs.py SITE.toml [SITE.toml ...]

The 121-component, 16-crane sites of docs/performance.md are made with

    multicrane generate hall --seed 0 --bays-x 4 --bays-y 8 --storeys 1 --span 4 \
        --column-height 4 --cranes 16 --random-start --no-interchangeable --yard one \
        --obstacles 2 -o s121.toml        # and --interchangeable for s121i.toml

Prints one line per file: load (``load_scenario``), environment construction, two resets,
the mean joint step over 300 random legal joint actions, and the prioritized planner's
slowest and mean call over one episode from ``reset(seed=0)``.
"""

from __future__ import annotations

import sys
import time

import numpy as np

import multicrane
import policies
from multicrane.episodes.rollout import run_episode
from multicrane.scenario.loader import load_scenario


def measure(path: str) -> str:
    t = time.perf_counter()
    s = load_scenario(path)
    load = time.perf_counter() - t
    t = time.perf_counter()
    env = multicrane.parallel_env(s)
    build = time.perf_counter() - t
    resets = []
    for seed in (0, 1):
        t = time.perf_counter()
        env.reset(seed=seed)
        resets.append(time.perf_counter() - t)
    rng = np.random.default_rng(0)
    obs, _ = env.reset(seed=0)
    n, t = 0, time.perf_counter()
    while n < 300 and env.agents:
        actions = {a: int(rng.choice(np.flatnonzero(obs[a]["action_mask"]))) for a in env.agents}
        obs, *_ = env.step(actions)
        n += 1
    step = (time.perf_counter() - t) / n
    policy = policies.make("prioritized", env, seed=0)
    calls: list[float] = []

    def timed(observation):
        t0 = time.perf_counter()
        action = policy(observation)
        calls.append(time.perf_counter() - t0)
        return action

    result = run_episode(env, timed, seed=0)
    return (
        f"{path}: {s.n_components} components, {s.cranes} cranes | load {load:.3f} s, "
        f"env {build:.3f} s, reset {resets[0]:.3f}/{resets[1]:.3f} s | step {step * 1e3:.2f} ms"
        f" | planner max {max(calls) * 1e3:.1f} ms, mean {np.mean(calls) * 1e3:.2f} ms"
        f" | solved {result['success']} in {result['steps']} steps"
    )


if __name__ == "__main__":
    for arg in sys.argv[1:]:
        print(measure(arg), flush=True)
