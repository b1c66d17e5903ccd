"""The planner's proposals (``multicrane.tasks.priority_rule.proposals``): the task-level
prioritized planner's own choices, asked as a dry run that changes no episode."""

from __future__ import annotations

import pytest

import multicrane
from multicrane.sim.simulator import NOBODY
from multicrane.tasks.priority_rule import proposals
from policies.task_planners import TaskPrioritized

CASES = [("hall-4c", 4, 0, None), ("hall-4c", 2, 3, None), ("frame2-3c", 3, 0, None),
         ("e3s2", 2, 1, None), ("hall-4c", 4, 1, "high")]  # fmt: skip


def _play(scenario, cranes, seed, events, ask: str | None):
    """Play the task-level prioritized planner; ``ask``: call ``proposals`` before
    (``"before"``) or after (``"after"``) the planner each round and check they agree.
    Returns the motion trace, the decisions and the carrier's counters."""
    env = multicrane.parallel_env(scenario, n_cranes=cranes, decisions="task", events=events)
    obs, _ = env.reset(seed=seed)
    planner = TaskPrioritized(env)
    book = env.mode.task_book()
    list_rank = {c: i for i, c in enumerate(env.scenario.order)}
    asked = 0
    while env.agents:
        before = proposals(book, list_rank) if ask == "before" else None
        joint = planner(obs)
        after = proposals(book, list_rank) if ask == "after" else None
        chosen = [joint[a] - 1 if joint[a] else NOBODY for a in env.possible_agents]
        for got in (before, after):
            if got is not None:
                assert got == chosen
                asked += any(p != NOBODY for p in got)
        obs, *_ = env.step(joint)
    if ask:
        assert asked > 5  # rounds where the planner started something
    return env.mode.trace, env.mode.decisions, dict(env.mode.carrier_stats())


@pytest.mark.parametrize("case", CASES, ids=lambda c: "-".join(map(str, c)))
def test_proposals_are_the_planners_choices_and_change_nothing(case):
    plain = _play(*case, None)
    assert _play(*case, "before") == plain
    assert _play(*case, "after") == plain  # the probes kept (a copy asked)


def test_no_proposals_when_no_crane_is_idle_or_the_site_is_done():
    env = multicrane.parallel_env("hall-4c", n_cranes=2, decisions="task")
    obs, _ = env.reset(seed=0)
    book = env.mode.task_book()
    list_rank = {c: i for i, c in enumerate(env.scenario.order)}
    planner = TaskPrioritized(env)
    seen_busy = False
    while env.agents:
        got = proposals(book, list_rank)
        for k in range(2):
            if book.busy(k):
                seen_busy = True
                assert got[k] == NOBODY
        obs, *_ = env.step(planner(obs))
    assert seen_busy
    assert proposals(book, list_rank) == [NOBODY, NOBODY]
