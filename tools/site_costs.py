"""Costs of one site: load, environment, reset, joint step (random legal actions), planner calls.

    PYTHONPATH=. python tools/site_costs.py SITE.toml [SITE.toml ...]

The 121-component, 16-crane sites of docs/performance.md are made with

    multicrane generate hall --seed 0 --bays-x 4 --bays-y 8 --storeys 1 --span 4 \
        --column-height 4 --cranes 16 --random-start --no-interchangeable --yard one \
        --obstacles 2 -o s121.toml        # and --interchangeable for s121i.toml

Prints one line per file: load (``load_scenario``), environment construction, two resets,
the mean joint step (the draw of a random legal joint action and ``env.step``; resets not
counted) over the first 300 steps of the episode from ``reset(seed=0)``, and the prioritized
planner's slowest and mean call over that episode (``multicrane.episodes.rollout`` plays and
times both; the draws come from ``multicrane.episodes.random_actions``).
"""

from __future__ import annotations

import sys
import time

import numpy as np

import multicrane
import policies
from multicrane.episodes.random_actions import random_legal_actions
from multicrane.episodes.rollout import Stopwatch, play, run_episode
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
    draws, steps = Stopwatch(), Stopwatch()

    def draw(observations: dict) -> dict:
        return random_legal_actions({a: o["action_mask"] for a, o in observations.items()}, rng)

    n = play(env, draws.timing(draw), 0, steps=300, step_watch=steps)
    step = (sum(draws.seconds) + sum(steps.seconds)) / n
    result = run_episode(env, policies.make("prioritized", env, seed=0), seed=0)
    return (
        f"{path}: {s.n_components} components, {s.cranes} cranes | load {load:.3f} s, "
        f"env {build:.3f} s, reset {resets[0]:.3f}/{resets[1]:.3f} s | step {step * 1e3:.2f} ms"
        f" | planner max {result['plan_ms_max']:.1f} ms, mean {result['plan_ms_per_step']:.2f}"
        f" ms | solved {result['success']} in {result['steps']} steps"
    )


if __name__ == "__main__":
    for arg in sys.argv[1:]:
        print(measure(arg), flush=True)
