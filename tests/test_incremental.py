"""Caches kept incrementally for speed equal a from-scratch computation at every step.

Target readiness (``Legality._update_targets``), each component's "has a ready target" flag,
the claimable list, and the joint observation (``Observer.observe_all``, one broadcast of
the shared part) against the per-crane ``observe`` it replaced.
"""

from __future__ import annotations

import numpy as np
import pytest

import multicrane
import policies
from multicrane.generator import generate


def _reference(sim):
    n = sim.site.n_components
    ready = [sim._target_ready_now(t) for t in range(n)]
    has = [any(ready[t] for t in sim.site.compatible[c]) for c in range(n)]
    claimable = [c for c in range(n) if sim.claimable(c)] if not sim.auto else []
    return ready, has, claimable


def _sites():
    small = generate("frame", 5, bays_x=2, bays_y=1, storeys=2, cranes=3, obstacles=0,
                     interchangeable=True, random_start=False)  # fmt: skip
    return [("e3s2", 2, False), ("e1s4", 1, True), ("frame2-3c", 3, False), (small, 3, False)]


@pytest.mark.parametrize(("scenario", "cranes", "auto"), _sites())
def test_incremental_readiness_equals_full_recompute(scenario, cranes, auto):
    env = multicrane.parallel_env(scenario, n_cranes=cranes, auto=auto)
    obs, _ = env.reset(seed=1)
    rng = np.random.default_rng(1)
    sim = env.sim
    name = "random" if auto else "prioritized"  # the auto mode moves the listed component
    plan = policies.make(name, env, seed=1)
    changes, before = 0, None
    for _ in range(600):
        ready, has, claimable = _reference(sim)
        changes += before is not None and ready != before
        before = ready
        assert sim.target_ready == ready
        assert sim._has_ready == has
        assert sim.claimable_components() == claimable
        if not env.agents:
            obs, _ = env.reset()
            plan = policies.make(name, env, seed=1)
            continue
        if rng.random() < 0.8:  # mostly the planner, so that targets fill and assemble
            actions = plan(obs)
        else:
            actions = {
                a: int(rng.choice(np.flatnonzero(obs[a]["action_mask"]))) for a in env.agents
            }
        obs, *_ = env.step(actions)
    assert changes > 0  # readiness did change along the way


@pytest.mark.parametrize(("scenario", "cranes"), [("e3s2", 2), ("frame2-3c", 3)])
def test_joint_observation_rows_equal_per_crane_observe_and_stay_fresh(scenario, cranes):
    env = multicrane.parallel_env(scenario, n_cranes=cranes)
    obs, _ = env.reset(seed=2)
    rng = np.random.default_rng(2)
    kept = []
    for _ in range(60):
        if not env.agents:
            break
        for i, agent in enumerate(env.possible_agents):
            mine = obs[agent]["observation"]
            np.testing.assert_array_equal(mine, env.observer.observe(i))  # bit for bit
            kept.append((mine, mine.copy()))
        np.testing.assert_array_equal(
            env.state(), np.concatenate([obs[a]["observation"] for a in env.possible_agents])
        )
        actions = {
            a: int(rng.choice(np.flatnonzero(obs[a]["action_mask"]))) for a in env.agents
        }
        obs, *_ = env.step(actions)
    for handed, copy in kept:  # later steps never wrote into an observation handed out
        np.testing.assert_array_equal(handed, copy)
