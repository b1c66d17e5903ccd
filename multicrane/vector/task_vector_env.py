"""``TaskVectorEnv``: B copies of one scenario at the task decision level, stepped together.

Each copy is the MDP of ``multicrane.parallel_env(scenario, decisions="task",
obs_format="flat", ...)``, round for round and number for number: the same start and crane
orders from the copy's generator, the same task book, carrier plans, space-time searches,
observations, masks, rewards and counts. The site lives in the motion mode's arrays
(``multicrane.vector.motion_state``), the task book and the carrier in
``multicrane.vector.task_state``; ``multicrane.vector.task_step`` runs a round of every copy
in one call (docs/vector.md).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from gymnasium import spaces

from multicrane.core.schema import Scenario
from multicrane.envs.boundary import require_reset
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.envs.infos import TASK_EVENTS
from multicrane.sim.events import EventSpec
from multicrane.sim.shortest_paths import UNREACHABLE
from multicrane.tasks.book import static_lengths
from multicrane.tasks.carrier import STAT_NAMES
from multicrane.tasks.priority_rule import check_rank, list_ranks, rank_pairs
from multicrane.tasks.support_graph import site_chains
from multicrane.vector.compiled import DirectCalls
from multicrane.vector.copies import CraneCopies
from multicrane.vector.motion_site import compile_motion_site
from multicrane.vector.motion_state import allocate
from multicrane.vector.task_rules import propose_batch
from multicrane.vector.task_site import compile_task_site
from multicrane.vector.task_state import allocate_scratch, allocate_tasks
from multicrane.vector.task_step import observe_copies, reset_starts, step_batch


class TaskVectorEnv(CraneCopies):
    """``num_envs`` copies of ``MultiCraneEnv(scenario, n_cranes, decisions="task",
    obs_format="flat", ...)``.

    **Arrays.** ``reset`` and ``step`` return observations ``[B, N, D]`` (float32; row ``k``
    is ``crane_k``'s task observation), rewards ``[B, N]`` (the team reward, or each crane's
    share with ``reward_mode="split"``), terminations and truncations ``[B, N]`` and infos;
    ``action_masks()`` is ``[B, N, 1 + P]`` (int8). Actions are ``[B, N]`` integers: 0 waits
    (or continues), ``1 + p`` takes task ``p``.

    **Options.** ``scenario``, ``n_cranes``, ``max_steps``, ``max_cycles``, ``reward``,
    ``reward_mode``, ``task_patience`` and ``strict`` as ``MultiCraneEnv``; crane reach comes
    from the scenario. Site events and the site planes are not modelled (ValueError).

    **Seeds, autoreset, buffers** as ``MotionVectorEnv``: copy ``i`` draws from the ``i``-th
    child of ``SeedSequence(seed)`` (or ``seed[i]``, as ``MultiCraneEnv.reset(seed=seed[i])``);
    a copy whose episode ends is reset in the same step, its last observations in
    ``infos["final_obs"]``; the arrays returned are the env's own unless ``copy=True``.

    **Infos** (arrays over the copies, as the one-site env's per-crane infos):
    ``event_counts`` ``[B, N, len(EventType)]``, ``reward_term`` ``[B, N]``,
    ``task_event_counts`` ``[B, N, 5]``, ``elapsed`` ``[B]`` and ``crane_steps`` ``[B]``,
    ``final_obs``.
    """

    def __init__(
        self,
        num_envs: int = 1,
        scenario: str | Path | Scenario = "hall-4c",
        n_cranes: int | None = None,
        max_steps: int | None = None,
        max_cycles: int | None = None,
        reward: str = "paper",
        reward_mode: str = "team",
        task_patience: int = 20,
        strict: bool = False,
        events: EventSpec | str | None = None,
        copy: bool = False,
    ):
        n = self._set_up_copies(num_envs, copy)
        options = dict(max_steps=max_steps, max_cycles=max_cycles, reward=reward,
                       reward_mode=reward_mode, obs_format="flat", events=events)  # fmt: skip
        self.reference = MultiCraneEnv(
            scenario, n_cranes, decisions="task", task_patience=task_patience, **options
        )
        self.scenario = self.reference.scenario
        self.task_site = compile_task_site(self.reference)
        motion = MultiCraneEnv(self.scenario, n_cranes, decisions="motion", **options)
        self.site = compile_motion_site(motion)
        self.n_cranes = self.site.n_cranes
        self.n_actions = self.reference.n_actions
        self.strict = bool(strict)
        self.single_observation_space = self.reference.observation_space("crane_0")
        self.single_action_space = spaces.Discrete(self.n_actions)
        self.state, self.motion_buffers = allocate(self.site, n, observed=False)
        self.tasks, self.buffers = allocate_tasks(self.task_site, n, self.n_cranes)
        self.scratch, self.search_scratch = allocate_scratch(
            self.task_site, self.site, self.n_cranes
        )
        self._book = self.reference.mode.task_book()
        self._rule: tuple | None = None  # (rank, list ranks) of the rankings kept
        self._rule_key: tuple | None = None  # (rank, order) as asked
        self._call = DirectCalls()
        self._flags = np.zeros((4, len(self.site.length)), dtype=bool)  # the rule's scratch
        self._ranking = None  # (comp, target, count): each copy's ranked pairs

    # -- episodes ----------------------------------------------------------------------------

    def reset(self, *, seed: int | Sequence[int | None] | None = None, options=None):
        """Reset every copy (see the class doc for ``seed``)."""
        self._seed(seed)
        failed = reset_starts(self.site, self.state, self.motion_buffers, self.tasks, self._all)
        if failed >= 0:
            self._no_start(failed)
        self._finish_resets(self._all)
        buf = self.buffers
        for array in (buf.rewards, buf.terms, buf.terminated, buf.truncated, buf.task_counts,
                      buf.elapsed, buf.crane_steps, self.motion_buffers.event_counts):  # fmt: skip
            array[...] = 0
        self._done[:] = False
        return self._out(buf.obs), self._infos()

    def step(self, actions):
        """One decision round of every copy (autoresets included); see the class doc."""
        require_reset(self._started, "step")
        a = self._actions(actions)
        if self.strict:
            self._check_masks(a)
        buf = self.buffers
        bad_copy, bad_crane, failed = self._call(
            step_batch, self.site, self.state, self.motion_buffers, self.task_site, self.tasks,
            buf, self.scratch, self.search_scratch, a,
        )  # fmt: skip
        if bad_copy >= 0:
            self._out_of_range(bad_copy, bad_crane, a[bad_copy, bad_crane])
        if failed >= 0:
            self._no_start(failed)
        if buf.ended.any():
            self._finish_resets(buf.ended)
        return self._step_outputs(-1)

    def _finish_resets(self, which: np.ndarray) -> None:
        """The episode's static path lengths of the copies in ``which`` (the task book's own
        breadth-first searches, cached for the site), then their observations."""
        book, site, tt = self._book, self.reference.sim.site, self.tasks
        observer = self.reference.mode.observer
        for b in np.flatnonzero(which):
            pickup = self._pickup(b)
            static_len = static_lengths(site, book.static, book.tasks, pickup, self.n_cranes)
            static_ok = static_len != UNREACHABLE
            tt.static_len[b] = static_len
            tt.static_ok[b] = static_ok
            columns = observer.episode_columns(static_len, static_ok)
            tt.episode_tasks[b] = columns.tasks.reshape(self.n_cranes, -1)
            tt.pair_len[b] = columns.pair_len
            tt.reach_can[b] = columns.reach
            if self._rule is not None:
                self._rank_copy(b, pickup)
        self._call(observe_copies, self.site, self.state, self.task_site, tt, self.buffers,
                   self.scratch, np.asarray(which, dtype=bool))  # fmt: skip

    # -- the prioritized rule ---------------------------------------------------------------

    def propose(self, rank: str = "list", max_searches: int = 8, order=None) -> np.ndarray:
        """The prioritized rule's actions ``[B, N]`` for every copy
        (``multicrane.tasks.priority_rule.propose``, what ``policies.task_planners``'
        ``TaskPrioritized(rank=..., max_searches=..., order=...)`` sends the one-site env):
        ``env.step(env.propose())`` plays it. Its searches' plans are kept for the step."""
        require_reset(self._started, "propose")
        key = (rank, None if order is None else tuple(order))
        if self._rule is None or self._rule_key != key:
            rule = (check_rank(rank), list_ranks(self.scenario, order))
            self._rule_key = key
            self._rule = rule
            C = len(self.site.length)
            self._ranking = (np.zeros((self.num_envs, C * C), dtype=np.int64),
                             np.zeros((self.num_envs, C * C), dtype=np.int64),
                             np.zeros(self.num_envs, dtype=np.int64))  # fmt: skip
            for b in range(self.num_envs):
                self._rank_copy(b, self._pickup(b))
        out = np.zeros((self.num_envs, self.n_cranes), dtype=np.int64)
        self._call(propose_batch, self.site, self.state, self.task_site, self.tasks, self.scratch,
                   self.search_scratch, *self._ranking, int(max_searches), out, self._flags)
        return out

    def _rank_copy(self, b: int, pickup: list[list[int]]) -> None:
        """Copy ``b``'s ranked pairs for the kept rule (``priority_rule.rank_pairs``)."""
        rank, order = self._rule
        dist = self._book.carrier.goals.pair_distances(pickup)
        chains = site_chains(self.reference.sim.site)[0] if rank == "chain" else None
        comp, target, _ = rank_pairs(dist, rank, order, chains)
        comps, targets, counts = self._ranking
        comps[b, : len(comp)] = comp
        targets[b, : len(comp)] = target
        counts[b] = len(comp)

    def _pickup(self, b: int) -> list[list[int]]:
        """Copy ``b``'s pick-up poses as the one-site state lists them ([] when pre-built)."""
        return [
            [] if row[0] < 0 else row[:length].tolist()
            for row, length in zip(self.state.pickup[b], self.site.length, strict=True)
        ]

    def _infos(self) -> dict[str, np.ndarray]:
        buf, out = self.buffers, self._out
        return {
            "event_counts": out(self.motion_buffers.event_counts),
            "reward_term": out(buf.terms),
            "task_event_counts": out(buf.task_counts),
            "elapsed": out(buf.elapsed),
            "crane_steps": out(buf.crane_steps),
            **self._final_obs_infos(),
        }

    SNAPSHOT = (("state", "tasks"), ("buffers", "motion_buffers"))

    def set_state(self, saved) -> None:
        super().set_state(saved)
        self._rule = None  # the rule's rankings follow the copies' pick-up poses

    def carrier_stats(self, copy: int) -> dict[str, int]:
        """The carrier's counters of one copy (``MultiCraneEnv.mode.carrier_stats()``)."""
        return dict(zip(STAT_NAMES, self.tasks.stats[copy].tolist(), strict=False))

    def close(self) -> None:
        """Nothing to release (the arrays go with the env)."""


__all__ = ["TASK_EVENTS", "TaskVectorEnv"]
