"""The task book's quick queries against the table they summarise, on states drawn at random.

``TaskBook.allows(crane, p)`` must be ``allowed()[crane, p]`` and ``any_open()`` must be "some
idle crane's row of ``allowed()`` has a task", on every state hypothesis reaches by random
legal tasks (shipped scenarios, with and without site events).
"""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import multicrane
from multicrane.episodes.random_actions import random_legal_action

SITES = [("e2s2", 2, {}), ("hall-4c", 4, {}), ("towers-3c", 3, {}), ("e3s2", 2, {"events": "high"})]


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(SITES), st.integers(0, 10_000), st.integers(0, 30))
def test_quick_queries_are_the_table(site, seed, rounds):
    scenario, n, options = site
    env = multicrane.parallel_env(scenario, n_cranes=n, decisions="task", **options)
    observations, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    book = env.unwrapped.mode.task_book()
    for _ in range(rounds + 1):
        if not env.agents:
            return
        table = book.allowed()
        idle = book.idle_cranes()
        assert book.any_open() == (bool(idle) and bool(table[idle].any()))
        for k in range(n):
            for p in range(len(book.tasks)):
                assert book.allows(k, p) == table[k, p]
        actions = {}
        for a in env.agents:
            mask = observations[a]["action_mask"]
            actions[a] = random_legal_action(mask, rng) if mask[1:].any() else 0
        observations, *_ = env.step(actions)
