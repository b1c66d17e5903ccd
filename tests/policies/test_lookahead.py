"""The look-ahead task planner (``policies.lookahead``): legal, deterministic, no later than
the prioritized planner on the shipped sites measured here, and refused where it would cheat."""

from __future__ import annotations

import pytest
from conftest import play_legal

import policies
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.episodes.rollout import run_episode
from policies.lookahead import TaskLookahead

# (scenario, cranes): the prioritized planner's and the look-ahead's makespans from reset(0)
# (measured; the look-ahead is not guaranteed shorter in general, see the module doc).
MAKESPANS = {("e2s2", 2): (30, 28), ("e3s2", 2): (63, 57), ("precast-house", 3): (64, 63)}


def task_env(name: str, n: int, **options) -> MultiCraneEnv:
    return MultiCraneEnv(name, n_cranes=n, decisions="task", **options)


@pytest.mark.parametrize(("name", "n"), list(MAKESPANS))
def test_lookahead_finishes_sooner_than_the_planner(name, n):
    env = task_env(name, n)
    planner = run_episode(env, policies.make("prioritized", env, seed=0), seed=0)
    look = run_episode(env, policies.make("lookahead", env, seed=0), seed=0)
    assert planner["success"] and look["success"]
    assert (planner["steps"], look["steps"]) == MAKESPANS[(name, n)]


def test_lookahead_is_legal_and_leaves_the_real_site_alone():
    env = task_env("e3s2", 2)
    policy = TaskLookahead(env)
    play_legal(env, policy, seed=3, steps=200, label="lookahead")
    assert policy.rollouts > 0
    obs, _ = env.reset(seed=4)
    policy = TaskLookahead(env)
    for _ in range(5):
        before = (env.sim.state.step_count, env.sim.state.n_assembled)
        actions = policy(obs)
        assert (env.sim.state.step_count, env.sim.state.n_assembled) == before
        obs, *_ = env.step(actions)


def test_a_rollout_copy_starts_its_trace_afresh_and_leaves_the_episode_recordable():
    """The copies share no trace with the episode (a rollout is never recorded), and the real
    episode's trace stays whole: one physical joint action per simulated step."""
    env = task_env("e3s2", 2)
    obs, _ = env.reset(seed=2)
    policy = TaskLookahead(env)
    for _ in range(4):
        obs, *_ = env.step(policy(obs))
    trace = [list(step) for step in env.mode.trace]
    copy = policy._copy()
    assert copy.mode.trace == [] and copy.mode.decisions == []
    assert copy.mode.trace is not env.mode.trace
    copy.step(policy(obs))
    assert env.mode.trace == trace and len(copy.mode.trace) > 0
    episode = run_episode(env, TaskLookahead(env), seed=5)
    assert len(env.mode.trace) == episode["steps"]  # one physical joint action per step


def test_lookahead_is_deterministic():
    runs = []
    for _ in range(2):
        env = task_env("e3s2", 2)
        runs.append(run_episode(env, policies.make("lookahead", env, seed=1), seed=1,
                                record=True)["actions"])  # fmt: skip
    assert runs[0] == runs[1]


def test_no_candidates_still_compares_waiting():
    env = task_env("e2s2", 2)
    episode = run_episode(env, policies.make("lookahead", env, seed=0, candidates=0), seed=0)
    assert episode["success"] and episode["steps"] <= MAKESPANS[("e2s2", 2)][0]


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"decisions": "motion"}, "drives task decisions"),
        ({"decisions": "task", "events": "low"}, "future site events"),
    ],
)
def test_lookahead_is_refused_where_it_cannot_play_fair(options, message):
    env = MultiCraneEnv("e3s2", n_cranes=2, **options)
    env.reset(seed=0)
    with pytest.raises(policies.PolicyError, match=message):
        policies.make("lookahead", env, seed=0)


def test_bad_candidates_are_refused():
    with pytest.raises(ValueError, match="candidates"):
        TaskLookahead(task_env("e2s2", 2), candidates=-1)


def test_a_budget_bounds_the_candidates_tried():
    env = task_env("e3s2", 2)
    planner = run_episode(env, policies.make("prioritized", env, seed=1), seed=1, record=True)
    free = run_episode(env, policies.make("lookahead", env, seed=1), seed=1, record=True)
    roomy = run_episode(env, policies.make("lookahead", env, seed=1, budget=1e6), seed=1,
                        record=True)  # fmt: skip
    tight = TaskLookahead(env, budget=1e-9)  # no time for anything but the planner's own
    none_tried = run_episode(env, tight, seed=1, record=True)
    assert roomy["actions"] == free["actions"] != planner["actions"]
    assert none_tried["actions"] == planner["actions"]
    # at most one rollout a round (the planner's joint action), against several without
    assert 0 < tight.rollouts <= none_tried["decision_rounds"]


@pytest.mark.parametrize("budget", [0, -1.0, "1", float("nan")])
def test_a_bad_budget_is_refused(budget):
    with pytest.raises(ValueError, match="budget"):
        TaskLookahead(task_env("e2s2", 2), budget=budget)
