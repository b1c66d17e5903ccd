"""CPU-time costs of one site (less sensitive to other jobs than wall time): step, planner, shaping.

    PYTHONPATH=. python tools/cpu_costs.py SITE.toml [SITE.toml ...]
    PYTHONPATH=. python tools/cpu_costs.py --shaping     # hall-4c, 4 cranes

Per site (``time.process_time``): load, reset, the mean joint step over 300 random legal
joint actions, and the prioritized planner's slowest and mean call over the episode from
``reset(seed=0)``. With ``--shaping``: the default potential's share of step + potential
over 3,000 random legal steps of hall-4c with 4 cranes (docs/performance.md).
"""

from __future__ import annotations

import sys
import time

import numpy as np

import multicrane
import policies
from multicrane.scenario.loader import load_scenario


def _random_steps(env, obs, rng, n: int, after=None) -> tuple[float, float]:
    """CPU seconds in ``env.step`` and in ``after()`` over n random legal joint steps."""
    agents = env.possible_agents
    in_step = in_after = 0.0
    for _ in range(n):
        masks = np.stack([obs[a]["action_mask"] for a in agents])
        choice = (rng.random(masks.shape) * masks).argmax(axis=1).tolist()
        c = time.process_time()
        obs, *_ = env.step(dict(zip(agents, choice, strict=True)))
        in_step += time.process_time() - c
        if after is not None:
            c = time.process_time()
            after()
            in_after += time.process_time() - c
        if not env.agents:
            obs, _ = env.reset()
    return in_step, in_after


def site(path: str) -> str:
    c = time.process_time()
    s = load_scenario(path)
    load = time.process_time() - c
    env = multicrane.parallel_env(s)
    c = time.process_time()
    obs, _ = env.reset(seed=0)
    reset = time.process_time() - c
    step, _ = _random_steps(env, obs, np.random.default_rng(0), 300)
    obs, _ = env.reset(seed=0)
    policy = policies.make("prioritized", env, seed=0)
    calls = []
    while env.agents:
        c = time.process_time()
        actions = policy(obs)
        calls.append(time.process_time() - c)
        obs, *_ = env.step(actions)
    return (
        f"{path}: {s.n_components} components, {s.cranes} cranes | cpu load {load:.3f} s, "
        f"reset {reset * 1e3:.1f} ms, joint step {step / 300 * 1e3:.2f} ms | planner max "
        f"{max(calls) * 1e3:.1f} ms, mean {np.mean(calls) * 1e3:.2f} ms over {len(calls)} calls"
        f" | solved {env.sim.done}"
    )


def shaping() -> str:
    from multicrane.training.shaping import DistancePotential

    env = multicrane.parallel_env("hall-4c", n_cranes=4)
    obs, _ = env.reset(seed=0)
    phi = DistancePotential(env.sim)
    step, potential = _random_steps(env, obs, np.random.default_rng(0), 3000, phi)
    return (
        f"hall-4c, 4 cranes: step {step / 3 :.3f} ms, potential {potential / 3:.3f} ms, "
        f"share {potential / (step + potential):.0%}"
    )


if __name__ == "__main__":
    for arg in sys.argv[1:]:
        print(shaping() if arg == "--shaping" else site(arg), flush=True)
