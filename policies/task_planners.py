"""Task-level planners: the prioritized rule, greedy and random, choosing tasks for idle cranes.

They drive ``MultiCraneEnv(decisions="task")`` (``multicrane.tasks.book``: action ``0`` wait or
continue, ``1 + p`` task ``p``); the environment's carrier moves the components.

- ``TaskPrioritized``: the prioritized planner's rule (``policies.prioritized``): ready pairs
  ranked by list order then distance (or distance alone, or the target's chain first:
  ``rank=``); for each pair in that order the first idle crane allowed to take it asks
  ``env.task_feasible(crane, p)`` (the carrier's space-time search, kept for the step if the
  crane then chooses it), at most ``max_searches`` searches per decision. It gives the
  motion-mode planner's makespans. ``order``: a list order of its own (every component index
  once) in place of the scenario's, e.g. a sequence planned elsewhere (``tools/order_probe.py``
  replays the order another planner started the components in).
- ``TaskGreedy``: each idle crane, in crane order, takes the allowed task with the shortest
  static path (ties: the lower task number), without a search (a blocked task is held and
  retried by the environment).
- ``TaskRandom``: each idle crane takes a uniformly random allowed task (wait when none).
"""

from __future__ import annotations

import numpy as np

from multicrane.envs.decision_modes import task_level
from multicrane.episodes.random_actions import random_legal_action
from multicrane.sim.simulator import NOBODY
from multicrane.tasks.priority_rule import check_rank, list_ranks, propose


def _book(env):
    """The unwrapped environment and its task book (``ValueError`` below the task level)."""
    if not task_level(env):
        raise ValueError("task-level planners drive MultiCraneEnv(decisions='task')")
    base = env.unwrapped if hasattr(env, "unwrapped") else env
    return base, base.mode.task_book()


class TaskPrioritized:
    """The prioritized rule over tasks (see the module doc); ``stats`` are the carrier's."""

    def __init__(self, env, seed=None, max_searches: int = 8, rank: str = "list", order=None):
        self.env, _ = _book(env)
        self.seed = seed
        self.max_searches = max_searches
        self.rank = check_rank(rank)
        self._list_rank = list_ranks(self.env.scenario, order)

    @property
    def stats(self) -> dict:
        return self.env.mode.carrier_stats()

    def __call__(self, observations: dict) -> dict:
        book = self.env.mode.task_book()
        chosen = propose(book, self._list_rank, self.rank, self.max_searches)
        return {a: 1 + p if p != NOBODY else 0
                for a, p in zip(self.env.possible_agents, chosen, strict=True)}  # fmt: skip


class TaskGreedy:
    """Each idle crane takes its allowed task with the shortest static path."""

    def __init__(self, env, seed=None):
        self.env, _ = _book(env)
        self.seed = seed

    def __call__(self, observations: dict) -> dict:
        book = self.env.mode.task_book()
        agents = self.env.possible_agents
        actions = dict.fromkeys(agents, 0)
        allowed = book.allowed()
        used_c: set[int] = set()
        used_t: set[int] = set()
        for k in book.idle_cranes():
            lens = np.where(allowed[k], book.static_len[k], np.iinfo(np.int64).max)
            for p in np.argsort(lens, kind="stable"):
                if not allowed[k, p]:
                    break
                c, t = book.tasks.pairs[p]
                if c in used_c or t in used_t:
                    continue
                actions[agents[k]] = 1 + int(p)
                used_c.add(c)
                used_t.add(t)
                break
        return actions


class TaskRandom:
    """Each idle crane takes a uniformly random allowed task (from its own seed)."""

    def __init__(self, env, seed=None):
        self.env, _ = _book(env)
        self.rng = np.random.default_rng(seed)

    def __call__(self, observations: dict) -> dict:
        out = {}
        for a in self.env.possible_agents:
            tasks = observations[a]["action_mask"][1:]  # every action but waiting
            out[a] = 1 + random_legal_action(tasks, self.rng) if tasks.any() else 0
        return out
