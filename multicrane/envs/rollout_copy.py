"""Copies of a task-level environment for rollouts: planners play them to the end to judge a plan.

``rollout_copy(env)`` deep-copies an unwrapped ``MultiCraneEnv`` but shares what no episode
changes (the scenario, the site, the task list and the static path lengths, a cache of the
site's) and starts the episode's trace afresh: a rollout is never recorded, and the trace,
which grows with the episode, was half of a copy's cost. ``has_events(env)``: the site has
events; a copy then holds the episode's whole event schedule, so a rollout would see late
components and breakdowns before they happen, and planners that play copies refuse it.
"""

from __future__ import annotations

import copy


def has_events(env) -> bool:
    """True when the (unwrapped) environment's site has events."""
    return env.sim.schedule is not None or env.observation_layout.events is not None


def rollout_copy(env):
    """A deep copy of the unwrapped task-level ``env`` for a rollout (module doc)."""
    mode = env.mode
    book = mode.task_book()
    shared = (env.scenario, env.sim.scenario, env.sim.site, env.observation_layout,
              book.tasks, book.static)  # fmt: skip
    memo = {id(x): x for x in shared}
    for trace in (mode.trace, mode.trace_events, mode.trace_rewards, mode.decisions):
        memo[id(trace)] = []
    return copy.deepcopy(env, memo)
