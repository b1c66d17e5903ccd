"""``ranked_pairs`` (numpy, from the carrier's per-episode distance table) against the loop it
replaced: the same pairs in the same order, on states drawn at random, for every rank."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import multicrane
from multicrane.episodes.random_actions import random_legal_action
from multicrane.tasks.goal_poses import goal_position, manhattan
from multicrane.tasks.support_graph import support_chains
from policies.prioritized import ranked_pairs


def reference_pairs(sim, candidates, taken, rank, list_rank):
    """The specification: every candidate's ready targets, one goal pose at a time."""
    pairs = []
    for comp in candidates:
        pick = sim.state.pickup[comp]
        rel = tuple(j - pick[0] for j in pick)
        here = sim.site.cell(pick[0])
        for t in sim.ready_targets(comp):
            if t in taken:
                continue
            goal = goal_position(rel, sim.site.target_cells[t])
            if goal is not None:
                pairs.append((manhattan(here, sim.site.cell(goal)), comp, t))
    if rank == "list":
        pairs.sort(key=lambda p: (list_rank[p[1]], p[0], p[2]))
    elif rank == "chain":
        chain, _ = support_chains(sim.site.target_supports)
        pairs.sort(key=lambda p: (-chain[p[2]], list_rank[p[1]], p[0], p[2]))
    else:
        pairs.sort()
    return pairs


SITES = [("e2s2", 2), ("hall-4c", 4), ("precast-house", 2), ("e4s3", 3)]


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(SITES), st.integers(0, 10_000), st.integers(0, 25), st.data())
def test_ranked_pairs_are_the_reference(site, seed, rounds, data):
    scenario, n = site
    env = multicrane.parallel_env(scenario, n_cranes=n, decisions="task")
    observations, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    sim = env.unwrapped.sim
    carrier = env.unwrapped.mode.task_book().carrier
    list_rank = {c: i for i, c in enumerate(env.unwrapped.scenario.order)}
    for _ in range(rounds + 1):
        if not env.agents:
            return
        candidates = sim.claimable_components()
        taken = set(data.draw(st.lists(st.integers(0, len(sim.site.target_cells) - 1),
                                       max_size=3)))  # fmt: skip
        for rank in ("list", "nearest", "chain"):
            expected = reference_pairs(sim, candidates, taken, rank, list_rank)
            assert ranked_pairs(carrier, candidates, taken, rank, list_rank) == expected
        actions = {}
        for a in env.agents:
            mask = observations[a]["action_mask"]
            actions[a] = random_legal_action(mask, rng) if mask[1:].any() else 0
        observations, *_ = env.step(actions)
