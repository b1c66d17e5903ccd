"""The prioritized rule's critical-path rank (``rank="chain"``): chosen by name, refused with
the valid names when misspelt, and a different plan where the chains disagree with the list."""

from __future__ import annotations

import pytest

import policies
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.scenario.named_sets import resolve_set
from multicrane.tasks.support_graph import site_chains
from policies.prioritized import PrioritizedPlanner
from policies.task_planners import TaskPrioritized


def _makespan(env, planner, seed=0):
    obs, _ = env.reset(seed=seed)
    while env.agents:
        obs, *_ = env.step(planner(obs))
    return env.sim.state.step_count, [list(d) for d in env.mode.decisions]


def test_a_misspelt_rank_names_the_valid_ones():
    env = MultiCraneEnv("hall-4c", n_cranes=4, decisions="task")
    with pytest.raises(ValueError, match="list, nearest, chain, got 'tallest'"):
        TaskPrioritized(env, rank="tallest")
    with pytest.raises(ValueError, match="got 'tallest'"):
        PrioritizedPlanner(MultiCraneEnv("hall-4c", n_cranes=4), rank="tallest")
    assert policies.make("prioritized:rank=chain", env).rank == "chain"


def test_the_chain_rank_plans_otherwise_where_the_list_order_is_not_the_chain_order():
    """On the first test-small sites whose list order puts a shorter chain before a longer
    one, the two ranks play different episodes, and both finish."""
    differ = 0
    for _, scenario in resolve_set("set:test-small")[:6]:
        env = MultiCraneEnv(scenario, decisions="task")
        chain = site_chains(env.sim.site)[0]
        listed = [int(chain[c]) for c in env.scenario.order]
        if listed == sorted(listed, reverse=True):
            continue
        by_list = _makespan(env, TaskPrioritized(env))
        by_chain = _makespan(env, TaskPrioritized(env, rank="chain"))
        assert env.sim.done
        differ += by_list[1] != by_chain[1]
    assert differ >= 2


def test_both_decision_levels_play_the_chain_rank_to_the_same_makespan():
    """The motion-level planner and the task-level one share the rule, as with the list
    rank: the same makespan on generated sites where the two ranks differ."""
    from multicrane.episodes.rollout import run_episode

    for _, scenario in resolve_set("set:test-small")[:3]:
        spans = []
        for decisions in ("motion", "task"):
            env = MultiCraneEnv(scenario, decisions=decisions)
            planner = policies.make("prioritized:rank=chain", env, seed=0)
            spans.append(run_episode(env, planner, seed=3)["makespan"])
        assert spans[0] == spans[1], (scenario.name, spans)
