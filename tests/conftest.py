"""Shared helpers for the environment tests.

``SCENARIOS`` (every shipped scenario, read once at import so that test modules can build their
parametrization from it) and ``random_masked_actions`` (a uniformly random legal action per
agent) are imported by the test modules with ``from conftest import ...``; the fixtures below
hand the same objects to tests that prefer fixtures.
"""

from __future__ import annotations

import os

# Keep numerical libraries to one thread: the suite steps many small environments.
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import pytest  # noqa: E402

import multicrane  # noqa: E402

SCENARIOS: list[str] = multicrane.scenario_names()


def random_masked_actions(obs: dict, rng: np.random.Generator) -> dict[str, int]:
    """One uniformly random legal action per agent, from ``obs[agent]["action_mask"]``."""
    actions = {}
    for agent, o in obs.items():
        legal = np.flatnonzero(o["action_mask"])
        assert legal.size, f"{agent}: the action mask allows nothing"
        actions[agent] = int(legal[rng.integers(legal.size)])
    return actions


@pytest.fixture(scope="session")
def scenarios() -> list[str]:
    """The shipped scenario names."""
    return list(SCENARIOS)


@pytest.fixture
def masked_actions():
    """The ``random_masked_actions`` helper."""
    return random_masked_actions
