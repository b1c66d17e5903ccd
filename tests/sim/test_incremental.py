"""Caches kept incrementally for speed, and fast searches, equal a from-scratch computation.

The breadth-first search (index-array frontier) against the whole-array one; target
readiness (``Legality._update_targets``), each component's "has a ready target" flag and the
claimable list against a full recompute at every step; the joint observation
(``Observer.observe_all``, one broadcast of the shared part) against per-crane ``observe``.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import multicrane
import policies
from multicrane.episodes.random_actions import random_legal_action
from multicrane.scenario.generator import generate


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
                a: random_legal_action(obs[a]["action_mask"], rng) for a in env.agents
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
            a: random_legal_action(obs[a]["action_mask"], rng) for a in env.agents
        }
        obs, *_ = env.step(actions)
    for handed, copy in kept:  # later steps never wrote into an observation handed out
        np.testing.assert_array_equal(handed, copy)


def _dense_breadth_first(ok, starts, deltas, through=None):
    """The whole-array breadth-first search that ``grid_search.breadth_first`` replaced."""
    n = ok.size
    dist = np.full(n, -1, dtype=np.int32)
    frontier = np.zeros(n, dtype=bool)
    frontier[[s for s in starts if ok[s]]] = True
    dist[frontier] = 0
    seen = frontier.copy()
    if through is not None:
        frontier &= through
    depth = 0
    while frontier.any():
        depth += 1
        nxt = np.zeros(n, dtype=bool)
        for d in deltas:
            if d > 0:
                nxt[d:] |= frontier[: n - d]
            else:
                nxt[: n + d] |= frontier[-d:]
        nxt &= ok & ~seen
        dist[nxt] = depth
        seen |= nxt
        frontier = nxt if through is None else nxt & through
    return dist


@settings(max_examples=60, deadline=None)
@given(
    shape=st.tuples(st.integers(1, 7), st.integers(1, 7), st.integers(1, 5)),
    density=st.floats(0.0, 0.6),
    seed=st.integers(0, 2**16),
    n_starts=st.integers(0, 4),
    use_through=st.booleans(),
)
def test_breadth_first_equals_the_whole_array_search(shape, density, seed, n_starts, use_through):
    from multicrane.sim.grid_search import breadth_first

    rng = np.random.default_rng(seed)
    X, Y, Z = shape
    ok = rng.random(X * Y * Z) >= density
    deltas = [Y * Z, -(Y * Z), Z, -Z, 1, -1]  # flat moves, wrapping at the rows like the grid's
    starts = rng.integers(0, ok.size, n_starts).tolist()
    through = rng.random(ok.size) < 0.8 if use_through else None
    expected = _dense_breadth_first(ok, starts, deltas, through)
    np.testing.assert_array_equal(breadth_first(ok, starts, deltas, through), expected)
