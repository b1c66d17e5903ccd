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
LEVELS = [(name, "motion") for name in SCENARIOS] + [
    ("e2s2", "task"),
    ("frame2-3c", "task"),
]


@pytest.fixture(autouse=True)
def _headless_viewer(monkeypatch):
    monkeypatch.setenv("MULTICRANE_RERUN_SINK", "memory")


@pytest.mark.parametrize(("name", "decisions"), LEVELS)
def test_pettingzoo_utilities_pass(name, decisions):
    par = functools.partial(multicrane.parallel_env, name, decisions=decisions)
    aec = functools.partial(multicrane.env, name, decisions=decisions)
    api_test(aec(), num_cycles=CYCLES)
    parallel_api_test(par(), num_cycles=CYCLES)
    seed_test(aec, num_cycles=CYCLES)
    parallel_seed_test(par, num_cycles=CYCLES)
    max_cycles_test(SimpleNamespace(parallel_env=par, env=aec))
    state_test(aec(), par(), num_cycles=CYCLES)
    # render_test needs render_mode="human" to construct; the ansi frames must be text.
    pytest.importorskip("rerun")
    render_test(aec)


def test_api_test_on_the_flat_observation():
    api_test(parallel_to_aec(multicrane.parallel_env("e3s2", obs_format="flat")), num_cycles=20)
    parallel_api_test(multicrane.parallel_env("e3s2", obs_format="flat"), num_cycles=20)
