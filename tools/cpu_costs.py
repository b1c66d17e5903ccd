"""CPU-time costs of one site (less sensitive to other jobs than wall time): step, planner, shaping.

    PYTHONPATH=. python tools/cpu_costs.py SITE.toml [SITE.toml ...]
    PYTHONPATH=. python tools/cpu_costs.py --shaping     # hall-4c, 4 cranes

Per site (``time.process_time``): load, reset, the mean ``env.step`` of a joint step over 300
random legal joint actions (``multicrane.episodes.random_actions``; the draws not counted),
and the prioritized planner's slowest and mean call over the episode from ``reset(seed=0)``
(episodes played by ``multicrane.episodes.rollout.play``). With ``--shaping``: the default
potential's share of step + potential over 3,000 random legal steps of hall-4c with 4 cranes
(docs/performance.md).
"""

from __future__ import annotations

import sys
import time

import numpy as np

import multicrane
import policies
from multicrane.episodes.random_actions import random_legal_policy
from multicrane.episodes.rollout import Stopwatch, play
from multicrane.scenario.loader import load_scenario


def _random_steps(env, n: int, after=None) -> tuple[float, float]:
    """CPU seconds in ``env.step`` alone and in ``after()`` (called after each step) over
    ``n`` random legal joint steps from ``reset(seed=0)`` (the draws and resets not counted)."""
    in_step, in_after = Stopwatch(time.process_time), Stopwatch(time.process_time)
    timed_after = None if after is None else in_after.timing(after)
    hook = None if after is None else (lambda _action, _out: timed_after())
    policy = random_legal_policy(env.possible_agents, np.random.default_rng(0))
    play(env, policy, 0, steps=n, repeat=True, step_watch=in_step, after_step=hook)
    return sum(in_step.seconds), sum(in_after.seconds)


def site(path: str) -> str:
    c = time.process_time()
    s = load_scenario(path)
    load = time.process_time() - c
    env = multicrane.parallel_env(s)
    c = time.process_time()
    env.reset(seed=0)
    reset = time.process_time() - c
    step, _ = _random_steps(env, 300)
    watch = Stopwatch(time.process_time)
    play(env, watch.timing(policies.make("prioritized", env, seed=0)), 0)
    calls = watch.seconds
    return (
        f"{path}: {s.n_components} components, {s.cranes} cranes | cpu load {load:.3f} s, "
        f"reset {reset * 1e3:.1f} ms, joint step {step / 300 * 1e3:.2f} ms | planner max "
        f"{max(calls) * 1e3:.1f} ms, mean {np.mean(calls) * 1e3:.2f} ms over {len(calls)} calls"
        f" | solved {env.sim.done}"
    )


def shaping() -> str:
    from multicrane.training.shaping import DistancePotential

    env = multicrane.parallel_env("hall-4c", n_cranes=4)
    env.reset(seed=0)
    phi = DistancePotential(env.sim)
    step, potential = _random_steps(env, 3000, phi)
    return (
        f"hall-4c, 4 cranes: step {step / 3 :.3f} ms, potential {potential / 3:.3f} ms, "
        f"share {potential / (step + potential):.0%}"
    )


if __name__ == "__main__":
    for arg in sys.argv[1:]:
        print(shaping() if arg == "--shaping" else site(arg), flush=True)
