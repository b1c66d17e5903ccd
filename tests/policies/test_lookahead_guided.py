"""The look-ahead search over another base policy (``TaskLookahead(base=...)``,
``LookaheadTeacher``): the default base is the prioritized planner, any base is called on
the round and on every copy, and the search never expects to finish after its base."""

from __future__ import annotations

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
