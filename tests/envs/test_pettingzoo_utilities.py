"""PettingZoo's own test utilities on every shipped scenario, both decision levels where cheap.

api_test (on the AEC form), parallel_api_test, seed_test, parallel_seed_test, max_cycles_test,
render_test (``ansi`` and ``human``, the latter into an in-memory rerun stream) and
state_test, each with a few cycles to keep the suite fast.
"""

from __future__ import annotations

import functools
from types import SimpleNamespace

import pytest
from conftest import SCENARIOS
from pettingzoo.test import (
    api_test,
    max_cycles_test,
    parallel_api_test,
    parallel_seed_test,
    render_test,
    seed_test,
    state_test,
)
from pettingzoo.utils.conversions import parallel_to_aec

import multicrane

CYCLES = 8
# pettingzoo.test.max_cycles_test truncates at a fixed 4 cycles and asserts that the parallel
# episode lasted exactly that long, so it only holds where no episode can end sooner.
PETTINGZOO_MAX_CYCLES = 4
LEVELS = [(name, "motion") for name in SCENARIOS] + [
    ("e2s2", "task"),
    ("frame2-3c", "task"),
]


@pytest.fixture(autouse=True)
def _headless_viewer(monkeypatch):
    monkeypatch.setenv("MULTICRANE_RERUN_SINK", "memory")


def _shortest_episode(env) -> int:
    """A lower bound on an episode's cycles: in task mode each crane assembles at most one
    component a round; a motion step never assembles (the smallest motion episode is long)."""
    if env.decisions != "task":
        return PETTINGZOO_MAX_CYCLES
    return -(-env.scenario.n_components // len(env.possible_agents))


def test_the_shortest_episode_bound_holds_on_e2s2_task():
    # 3 components, 1 crane: random play can finish in 3 rounds, under the test's 4 cycles.
    assert _shortest_episode(multicrane.parallel_env("e2s2", decisions="task")) == 3
    assert _shortest_episode(multicrane.parallel_env("frame2-3c", decisions="task")) >= 4


@pytest.mark.parametrize(("name", "decisions"), LEVELS)
def test_pettingzoo_utilities_pass(name, decisions):
    par = functools.partial(multicrane.parallel_env, name, decisions=decisions)
    aec = functools.partial(multicrane.env, name, decisions=decisions)
    api_test(aec(), num_cycles=CYCLES)
    parallel_api_test(par(), num_cycles=CYCLES)
    seed_test(aec, num_cycles=CYCLES)
    parallel_seed_test(par, num_cycles=CYCLES)
    if _shortest_episode(par()) >= PETTINGZOO_MAX_CYCLES:
        max_cycles_test(SimpleNamespace(parallel_env=par, env=aec))
    state_test(aec(), par(), num_cycles=CYCLES)
    # render_test needs render_mode="human" to construct; the ansi frames must be text.
    pytest.importorskip("rerun")
    render_test(aec)


def test_api_test_on_the_flat_observation():
    api_test(parallel_to_aec(multicrane.parallel_env("e3s2", obs_format="flat")), num_cycles=20)
    parallel_api_test(multicrane.parallel_env("e3s2", obs_format="flat"), num_cycles=20)
