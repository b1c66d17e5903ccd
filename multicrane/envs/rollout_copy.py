"""Copies of a task-level environment for rollouts: planners play them to the end to judge a plan.

``rollout_copy(env)`` deep-copies an unwrapped ``MultiCraneEnv`` but shares what no episode
changes (the scenario, the site, the task list, and the static path lengths, goal poses and
search inputs, caches of the site's (``multicrane.tasks.shape_cache``: its distance oracles
hold for any copy), and what the simulator keeps fixed for the episode,
``Simulator.shared_with_copies``), shares the episode's kept search answers
(``Carrier.share_searches``, ``multicrane.tasks.search_memo``: the copies ask the same
searches again and again), and starts the episode's trace afresh: a rollout is never recorded,
and the trace, which grows with the episode, was half of a copy's cost.
``has_events(env)``: the site has events; a copy then holds the episode's whole event
schedule, so a rollout would see late components and breakdowns before they happen, and
planners that play copies refuse it.
``collector_paused(pause)``: a block in which Python's cyclic garbage collector does not run
(rollouts make many objects, and a full collection scans every object of the process,
trained models included; the copies hold almost no reference cycles, so reference counting
frees them and nothing piles up).
"""

from __future__ import annotations

import contextlib
import copy
import gc


def has_events(env) -> bool:
    """True when the (unwrapped) environment's site has events."""
    return env.sim.schedule is not None or env.observation_layout.events is not None


def rollout_copy(env):
    """A deep copy of the unwrapped task-level ``env`` for a rollout (module doc)."""
    mode = env.mode
    book = mode.task_book()
    carrier = book.carrier
    shared = (env.scenario, env.sim.scenario, env.sim.site, env.observation_layout,
              book.tasks, book.static, carrier.goals, carrier.shapes, carrier.share_searches(),
              *env.sim.shared_with_copies())  # fmt: skip
    memo = {id(x): x for x in shared if x is not None}
    for trace in (mode.trace, mode.trace_events, mode.trace_rewards, mode.decisions):
        memo[id(trace)] = []
    return copy.deepcopy(env, memo)


@contextlib.contextmanager
def collector_paused(pause: bool = True):
    """Python's cyclic garbage collector off inside the block when ``pause`` (and it was on),
    back on after it (module doc)."""
    paused = pause and gc.isenabled()
    if paused:
        gc.disable()
    try:
        yield
    finally:
        if paused:
            gc.enable()
