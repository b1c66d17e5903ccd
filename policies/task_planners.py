"""Task-level planners: the prioritized rule, greedy and random, choosing tasks for idle cranes.

They drive ``MultiCraneEnv(decisions="task")`` (``multicrane.tasks.book``: action ``0`` wait or
continue, ``1 + p`` task ``p``); the environment's carrier moves the components.

- ``TaskPrioritized``: the prioritized planner's rule (``policies.prioritized``): ready pairs
  ranked by list order then distance (or distance alone, or the target's chain first:
  ``rank=``; with a scorer, by default the rank it was trained with, its ``meta["rank"]``);
  for each pair in that order the first idle crane allowed to take it asks
  ``env.task_feasible(crane, p)`` (the carrier's space-time search, kept for the step if the
  crane then chooses it), at most ``max_searches`` searches per decision. It gives the
  motion-mode planner's makespans. ``order``: a list order of its own (every component index
  once) in place of the scenario's, e.g. a sequence planned elsewhere (``tools/order_probe.py``
  replays the order another planner started the components in). ``scorer``: a learned list
  order instead (``multicrane.tasks.order_scorer.OrderScorer``, the path of its file, e.g.
  one ``tools/order_es.py`` trained, or the name of a scorer shipped in ``policies/scorers``:
  ``shipped_scorers()``, ``load_scorer``), computed from the components' static features at
  the first decision of each episode. ``guard``: at that decision, play the episode on copies of
  the site with this order and with the plain planner's (``rank="list"``, the scenario's
  order) and keep the shorter (ties: this order); on a site without events the copy's
  episode is the real one, so the guarded rule is never longer than the planner (it costs
  two episodes at reset; refused on sites with events). ``samples``: with a scorer, a search
  at that decision over the learned policy's own orders: the scorer's order and
  ``samples - 1`` orders drawn from the Plackett-Luce distribution of its scores
  (``OrderScorer.sampled_orders``, ``temperature``; the draws from the policy's seed) are
  each played on a copy of the site and the shortest is kept (ties: the earlier; with
  ``guard`` the planner's order is one more candidate); it costs ``samples`` episodes at reset
  and, like the guard, is refused on sites with events.
- ``TaskGreedy``: each idle crane, in crane order, takes the allowed task with the shortest
  static path (ties: the lower task number), without a search (a blocked task is held and
  retried by the environment).
- ``TaskRandom``: each idle crane takes a uniformly random allowed task (wait when none).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from multicrane.envs.decision_modes import task_level
from multicrane.envs.rollout_copy import collector_paused, has_events, rollout_copy
from multicrane.episodes.random_actions import random_legal_action
from multicrane.sim.simulator import NOBODY
from multicrane.tasks.order_scorer import OrderScorer, component_features
from multicrane.tasks.priority_rule import check_rank, list_ranks, propose


def _book(env):
    """The unwrapped environment and its task book (``ValueError`` below the task level)."""
    if not task_level(env):
        raise ValueError("task-level planners drive MultiCraneEnv(decisions='task')")
    base = env.unwrapped if hasattr(env, "unwrapped") else env
    return base, base.mode.task_book()


class TaskPrioritized:
    """The prioritized rule over tasks (see the module doc); ``stats`` are the carrier's."""

    reads_observations = False  # it reads the task book: a rollout may ``env.advance``

    def __init__(self, env, seed=None, max_searches: int = 8, rank: str | None = None,
                 order=None, scorer=None, guard: bool = False, samples: int = 1,
                 temperature: float = 0.5):  # fmt: skip
        self.env, _ = _book(env)
        self.seed = seed
        self.max_searches = max_searches
        if order is not None and scorer is not None:
            raise ValueError("give the rule an order or a scorer, not both")
        self.samples, self.temperature = _check_sampling(samples, temperature, scorer)
        for name, asked in (("guard", guard), ("samples", self.samples > 1)):
            if asked and has_events(self.env):
                raise ValueError(f"{name} plays copies of the environment, which hold the "
                                 "episode's future site events: use it on sites without "
                                 "events")  # fmt: skip
        self.scorer = None if scorer is None else load_scorer(scorer)
        if rank is None:  # a scorer's own rank, the one it was trained with
            rank = self.scorer.meta.get("rank", "list") if self.scorer else "list"
        self.rank = check_rank(rank)
        self.guard = bool(guard)
        self.rng = np.random.default_rng(seed)
        self.order = None if order is None else list(order)
        self._list_rank = list_ranks(self.env.scenario, order)
        self._rank = self.rank
        self._planned_state = None

    @property
    def stats(self) -> dict:
        return self.env.mode.carrier_stats()

    def __call__(self, observations: dict) -> dict:
        book = self.env.mode.task_book()
        if (self.scorer or self.guard) and self._planned_state is not self.env.sim.state:
            self._plan_episode(book)
        chosen = propose(book, self._list_rank, self._rank, self.max_searches)
        return {a: 1 + p if p != NOBODY else 0
                for a, p in zip(self.env.possible_agents, chosen, strict=True)}  # fmt: skip

    def _plan_episode(self, book) -> None:
        """At an episode's first decision: the scorer's order, or with ``samples`` and
        ``guard`` the shortest of the candidates played on copies of the site."""
        scenario = self.env.scenario
        orders = [self.order]
        if self.scorer is not None:
            features = component_features(book, scenario)
            orders = self.scorer.sampled_orders(features, scenario, self.samples,
                                                self.temperature, self.rng)  # fmt: skip
        candidates = [(self.rank, order) for order in orders]
        if self.guard:
            candidates.append(("list", None))
        rank, order = candidates[0]
        if len(candidates) > 1:
            with collector_paused():
                spans = [self._rollout(r, o) for r, o in candidates]
            rank, order = candidates[int(np.argmin(spans))]
        self._rank, self._list_rank = rank, list_ranks(scenario, order)
        self._planned_state = self.env.sim.state

    def _rollout(self, rank: str, order) -> float:
        """The makespan of the rule with ``rank`` and ``order`` on a copy of the site from
        here (``inf``: truncated)."""
        env = rollout_copy(self.env)
        rule = TaskPrioritized(env, max_searches=self.max_searches, rank=rank, order=order)
        while True:
            terminated, truncated = env.advance(rule({}))  # the rule reads no observations
            if terminated:
                return env.sim.state.step_count
            if truncated:
                return math.inf


SCORERS = Path(__file__).parent / "scorers"


def shipped_scorers() -> list[str]:
    """The names of the scorers shipped with the library (``policies/scorers/NAME.json``)."""
    return sorted(path.stem for path in SCORERS.glob("*.json"))


def load_scorer(scorer) -> OrderScorer:
    """``scorer`` as an ``OrderScorer``: one already, the path of a scorer file or of a run
    directory holding ``scorer.json``, or the name of a shipped scorer (``shipped_scorers``;
    an existing path of that name wins). ``ValueError`` names what is wrong."""
    if isinstance(scorer, OrderScorer):
        return scorer
    if not isinstance(scorer, str | Path):
        raise ValueError(f"scorer must be an OrderScorer, a path or a shipped scorer's name, "
                         f"got {scorer!r}")  # fmt: skip
    path = Path(scorer)
    if not path.exists():
        if str(scorer) not in shipped_scorers():
            raise ValueError(f"scorer {str(scorer)!r}: no such file or run directory, and not "
                             f"a shipped scorer ({', '.join(shipped_scorers())})")  # fmt: skip
        path = SCORERS / f"{scorer}.json"
    return OrderScorer.load(path)


def _check_sampling(samples, temperature, scorer) -> tuple[int, float]:
    """``samples`` and ``temperature`` checked: ``ValueError`` names the bad value."""
    if isinstance(samples, bool) or not isinstance(samples, int | np.integer) or samples < 1:
        raise ValueError(f"samples must be a whole number of orders, at least 1, got {samples!r}")
    if samples > 1 and scorer is None:
        raise ValueError("samples draws orders from a scorer's scores: give it a scorer")
    try:
        value = float(temperature)
    except (TypeError, ValueError):
        value = math.nan
    if isinstance(temperature, bool) or not (value > 0 and math.isfinite(value)):
        raise ValueError(f"temperature must be a positive number, got {temperature!r}")
    return int(samples), value


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
