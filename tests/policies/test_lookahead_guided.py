"""The look-ahead search over another base policy (``TaskLookahead(base=...)``,
``LookaheadTeacher``): the default base is the prioritized planner, any base is called on
the round and on every copy, and the search never expects to finish after its base."""

from __future__ import annotations

import numpy as np
import pytest

import policies
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.episodes.rollout import run_episode
from policies.lookahead import LookaheadTeacher, TaskLookahead
from policies.task_planners import TaskGreedy, TaskPrioritized


def _env() -> MultiCraneEnv:
    return MultiCraneEnv("e3s2", n_cranes=2, decisions="task")


def test_the_prioritized_base_given_is_the_default_search():
    env = _env()
    default = run_episode(env, policies.make("lookahead", env, seed=2), seed=2, record=True)
    given = run_episode(env, TaskLookahead(env, base=TaskPrioritized), seed=2, record=True)
    teacher = run_episode(env, LookaheadTeacher()(env, None), seed=2, record=True)
    assert default["actions"] == given["actions"] == teacher["actions"]


def test_a_guided_search_calls_its_base_and_finishes_no_later_than_it():
    made = []

    def base(env):
        made.append(env)
        return TaskGreedy(env)

    env = _env()
    greedy = run_episode(env, TaskGreedy(env), seed=5)
    search = LookaheadTeacher(candidates=2).guided(base)(env, None)
    guided = run_episode(env, search, seed=5)
    assert guided["success"] and guided["steps"] <= greedy["steps"]
    assert env in made  # the round's own proposal
    assert sum(e is not env for e in made) == search.rollouts > 0  # one per copy finished


class _FarthestFirst:
    """A stand-in for a learned guide: it scores each crane's allowed tasks by their static
    path length (the farthest best) and, as a policy, gives the first idle crane its third
    farthest task (a choice no 2-candidate list holds) and lets every other crane wait."""

    def __init__(self, env):
        self.env = env

    def scores(self, observations) -> np.ndarray:
        book = self.env.mode.task_book()
        rows = np.full((len(observations), 1 + len(book.tasks)), -1e9)
        for row, agent in enumerate(observations):
            crane = self.env.possible_agents.index(agent)
            rows[row, 1:] = book.static_len[crane]
        return rows

    def __call__(self, observations) -> dict:
        joint = dict.fromkeys(observations, 0)
        idle = self.env.mode.task_book().idle_cranes()
        if idle:
            agent = self.env.possible_agents[idle[0]]
            ranked = [a for a in _farthest_first(self.env, idle[0]) if a]
            joint[agent] = ranked[2] if len(ranked) > 2 else 0
        return joint


def _farthest_first(env, crane: int) -> list[int]:
    """The crane's allowed tasks as actions, the longest static path first."""
    book = env.mode.task_book()
    allowed = np.flatnonzero(book.allowed()[crane])
    order = np.argsort(-book.static_len[crane][allowed], kind="stable")
    return [1 + int(p) for p in allowed[order]]


def _first_round_tries(guide=None) -> tuple[set[int], list[int], list[int]]:
    """The first idle crane's actions a 2-candidate search tries in the first round, and its
    allowed tasks (as actions) farthest and nearest first."""
    env = _env()
    observations, _ = env.reset(seed=0)
    search = TaskLookahead(env, candidates=2, guide=guide)
    search(observations)
    agent, values = search.values
    book = env.mode.task_book()
    crane = env.possible_agents.index(agent)
    allowed = np.flatnonzero(book.allowed()[crane])
    nearest = [1 + int(p) for p in allowed[np.argsort(book.static_len[crane][allowed],
                                                       kind="stable")]]  # fmt: skip
    return set(values), _farthest_first(env, crane), nearest


def test_a_guide_chooses_the_candidates_and_adds_its_own_joint_action():
    tried, farthest, nearest = _first_round_tries(lambda env, seed: _FarthestFirst(env))
    assert set(farthest[:2]) <= tried and 0 in tried  # the guide's order, and waiting
    assert farthest[2] in tried  # the guide's own joint action
    unguided, _, _ = _first_round_tries()
    assert set(nearest[:2]) <= unguided and not set(farthest[:3]) & unguided


def test_a_guide_that_scores_nothing_is_refused():
    with pytest.raises(ValueError, match="guide=.*scores every crane's actions"):
        TaskLookahead(_env(), guide=lambda env, seed: TaskGreedy(env))


def test_a_guided_search_plays_legally_the_best_copys_joint_action():
    env = _env()
    search = TaskLookahead(env, candidates=2, guide=lambda env, seed: _FarthestFirst(env))
    observations, _ = env.reset(seed=3)
    rounds = 0
    while env.agents:
        joint = search(observations)
        for agent, action in joint.items():
            assert observations[agent]["action_mask"][action]
        if search.values is not None:  # the joint action played is the best copy's
            agent, values = search.values
            assert values[joint[agent]] == min(values.values())
            rounds += 1
        observations, *_ = env.step(joint)
    assert rounds > 0 and env.sim.state.n_assembled == len(env.scenario.components)
