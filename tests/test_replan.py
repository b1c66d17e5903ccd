"""Planners on sites with events: the replanning planner, the static plan, the benchmark.

Without events both planners are the static prioritized planner (same makespans). With events
(``MultiCraneEnv(events=...)``, docs/uncertainty.md) a hand-built schedule forces a breakdown
and a closed zone on a small site: the replanning planner routes around them and reassigns,
the static plan waits and takes longer; both finish every built-in scenario under ``low`` and
``high`` events for a few seeds (more seeds under the ``fuzz`` marker).
"""

from __future__ import annotations

import json

import pytest

import multicrane
import policies
from multicrane.reports.uncertainty import Cell, episode_seeds, markdown_table
from multicrane.rollout import run_episode


def play(name: str, scenario: str, n: int, seed: int, **env_options) -> tuple[dict, object]:
    env = multicrane.parallel_env(scenario, n_cranes=n, **env_options)
    policy = policies.make(name, env, seed=seed)
    return run_episode(env, policy, seed=seed), policy


@pytest.mark.parametrize(("scenario", "n"), [("e2s2", 2), ("e3s2", 3), ("hall-4c", 4)])
def test_static_plan_is_the_prioritized_episode_without_events(scenario, n):
    """On an undisturbed site the static plan's clock never stops: the same makespan."""
    for seed in (0, 1):
        static, policy = play("static-plan", scenario, n, seed)
        planned, _ = play("prioritized", scenario, n, seed)
        assert static["makespan"] == planned["makespan"] is not None
        assert policy.stats["waits"] == 0 and policy.stats["fallback"] == 0
        assert policy.stats["plan_steps"] == static["makespan"]


def test_replanning_is_the_prioritized_planner_without_events():
    a, _ = play("replanning", "e3s2", 2, 0)
    b, pb = play("prioritized", "e3s2", 2, 0)
    assert a["makespan"] == b["makespan"]
    assert "event_replans" not in pb.stats  # no events, no event counters


def test_static_plan_refuses_task_decisions():
    env = multicrane.parallel_env("e2s2", n_cranes=2, decisions="task")
    with pytest.raises(policies.PolicyError, match="'static-plan' drives motion decisions"):
        policies.make("static-plan", env, seed=0)


def test_new_names_are_listed_for_the_multi_agent_mode():
    assert {"replanning", "static-plan"} <= set(policies.names(False))


# -- the benchmark's arithmetic -----------------------------------------------------------------


def test_episode_seeds_and_refusals():
    assert episode_seeds(2, 2) == [0, 1, 1000, 1001]
    with pytest.raises(ValueError, match="at least 1"):
        episode_seeds(0, 1)


def test_cell_summary_and_table():
    cell = Cell("e2s2", 2, "high", "static-plan", [0, 1, 2], [30, 34, None])
    assert cell.completion == pytest.approx(2 / 3)
    assert cell.mean == 32.0
    lo, hi = cell.ci
    assert lo < 32.0 < hi
    json.dumps(cell.as_dict())
    table = markdown_table([cell, Cell("e2s2", 2, "high", "replanning", [0], [31])], [])
    assert "| e2s2 | 2 | high | 32.0 [" in table
    assert "(67%)" in table and "31.0 (100%)" in table
