"""The per-copy arrays of the task level: task book, carrier plans, outputs; leading axis ``B``.

``TaskState`` holds what ``multicrane.tasks.book.TaskBook`` and ``multicrane.tasks.carrier``
keep for one site, for ``B`` copies, beside the motion mode's ``MotionState`` (the site itself):
each crane's task, the episode's static path lengths, and the carrier's plans in ``S = N + 1``
slots. A plan slot holds what ``reservations.Plan`` holds, its positions included (room for
the longest path a search can return: its time cap is the distance to the goal, at most the
grid's positions, plus the slack), and its insertion number, so that the kernels visit plans
in the order of the carrier's dict. ``TaskBuffers`` holds what a step hands out:
observations ``[B, N, D]``, masks ``[B, N, 1 + P]``, rewards, flags and counts.
``TaskScratch`` (and the searches' ``SearchScratch``) is the kernels' working space, shared by
the copies, which a kernel steps one after the other: nothing in a kernel allocates.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from multicrane.envs.infos import TASK_EVENTS
from multicrane.tasks.carrier import STAT_NAMES
from multicrane.tasks.search_scratch import SearchScratch, search_scratch
from multicrane.vector.task_site import TASK_WIDTH, TaskSite


class TaskState(NamedTuple):
    """The task book and the carrier of ``B`` copies (``N`` cranes, ``C`` components, ``P``
    tasks, ``S`` plan slots; -1 means "none")."""

    # -- the episode's static paths (``TaskBook.static_len``, the observation's columns) ----
    static_len: np.ndarray  # (B, N, P) int64
    static_ok: np.ndarray  # (B, N, P) bool
    episode_tasks: np.ndarray  # (B, N, P * 9) float32: the tasks table but "allowed"
    pair_len: np.ndarray  # (B, P) float64: a task's shortest static path over the cranes
    reach_can: np.ndarray  # (B, C, N) bool: crane k can carry the component somewhere
    # -- the book --------------------------------------------------------------------------
    task: np.ndarray  # (B, N) int64: each crane's task
    since: np.ndarray  # (B, N) int64: when it was chosen
    started: np.ndarray  # (B, N) bool: the carrier has it
    tried: np.ndarray  # (B, N) int64: when a held task's search last ran
    cycles: np.ndarray  # (B,) int64: decision rounds this episode
    probe: np.ndarray  # (B, N) int64: the task ``feasible`` started for the crane this round
    probe_t: np.ndarray  # (B,) int64: the round of the probes, -1 none
    infeasible: np.ndarray  # (B, N, P) int64: T + 1 where ``feasible`` failed at time T
    # -- the carrier (plans in slots) --------------------------------------------------------
    slot_comp: np.ndarray  # (B, S) int64: the slot's component, -1 free
    slot_crane: np.ndarray  # (B, S) int64
    slot_target: np.ndarray  # (B, S) int64
    slot_t0: np.ndarray  # (B, S) int64: when the path starts
    slot_claim: np.ndarray  # (B, S) bool: the plan starts with the claim
    slot_len: np.ndarray  # (B, S) int64: the path's positions
    slot_pos: np.ndarray  # (B, S, Lp) int32: the path, one position per time step from t0
    slot_order: np.ndarray  # (B, S) int64: insertion number (the plans dict's order)
    n_inserted: np.ndarray  # (B,) int64
    seq: np.ndarray  # (B, C) int64: a component's first plan's creation number, 0 none
    n_seq: np.ndarray  # (B,) int64
    round_t: np.ndarray  # (B,) int64: the round's time, -1 none yet
    may_start: np.ndarray  # (B,) bool
    claims: np.ndarray  # (B, N) int64: the component each crane claims in the coming step
    round_searches: np.ndarray  # (B,) int64
    stats: np.ndarray  # (B, len(STAT_NAMES)) int64: the carrier's counters


class TaskBuffers(NamedTuple):
    """What a task-level step writes for the caller."""

    obs: np.ndarray  # (B, N, D) float32
    final_obs: np.ndarray  # (B, N, D) float32: the last observation of an ended episode
    masks: np.ndarray  # (B, N, 1 + P) int8
    rewards: np.ndarray  # (B, N) float64
    terms: np.ndarray  # (B, N) float64: each crane's share of the round's reward
    terminated: np.ndarray  # (B, N) bool
    truncated: np.ndarray  # (B, N) bool
    task_counts: np.ndarray  # (B, N, len(TASK_EVENTS)) int32: the round's task events
    elapsed: np.ndarray  # (B,) int64: simulated steps of the round
    crane_steps: np.ndarray  # (B,) int64: busy crane x step pairs of the round
    ended: np.ndarray  # (B,) bool: copies whose episode ended (to reset)


def path_room(site: TaskSite) -> int:
    """The longest path a search returns: its positions, one a time step up to the time cap
    (the start's distance to the goal, below the grid's positions, plus the slack)."""
    return len(site.coords) // 3 + site.slack + 1


def allocate_tasks(site: TaskSite, n: int, n_cranes: int) -> tuple[TaskState, TaskBuffers]:
    """Zeroed task state and buffers for ``n`` copies (reset them before use)."""
    N, P, C = n_cranes, len(site.task_comp), len(site.shape_of)
    S = N + 1
    minus = lambda *shape: np.full(shape, -1, dtype=np.int64)  # noqa: E731
    state = TaskState(
        static_len=np.zeros((n, N, P), dtype=np.int64),
        static_ok=np.zeros((n, N, P), dtype=bool),
        episode_tasks=np.zeros((n, N, P * TASK_WIDTH), dtype=np.float32),
        pair_len=np.zeros((n, P), dtype=np.float64),
        reach_can=np.zeros((n, C, N), dtype=bool),
        task=minus(n, N),
        since=np.zeros((n, N), dtype=np.int64),
        started=np.zeros((n, N), dtype=bool),
        tried=minus(n, N),
        cycles=np.zeros(n, dtype=np.int64),
        probe=minus(n, N),
        probe_t=minus(n),
        infeasible=np.zeros((n, N, P), dtype=np.int64),
        slot_comp=minus(n, S),
        slot_crane=minus(n, S),
        slot_target=minus(n, S),
        slot_t0=np.zeros((n, S), dtype=np.int64),
        slot_claim=np.zeros((n, S), dtype=bool),
        slot_len=np.zeros((n, S), dtype=np.int64),
        slot_pos=np.zeros((n, S, path_room(site)), dtype=np.int32),
        slot_order=np.zeros((n, S), dtype=np.int64),
        n_inserted=np.zeros(n, dtype=np.int64),
        seq=np.zeros((n, C), dtype=np.int64),
        n_seq=np.zeros(n, dtype=np.int64),
        round_t=minus(n),
        may_start=np.ones(n, dtype=bool),
        claims=minus(n, N),
        round_searches=np.zeros(n, dtype=np.int64),
        stats=np.zeros((n, len(STAT_NAMES)), dtype=np.int64),
    )
    buffers = TaskBuffers(
        obs=np.zeros((n, N, site.obs_size), dtype=np.float32),
        final_obs=np.zeros((n, N, site.obs_size), dtype=np.float32),
        masks=np.zeros((n, N, 1 + P), dtype=np.int8),
        rewards=np.zeros((n, N), dtype=np.float64),
        terms=np.zeros((n, N), dtype=np.float64),
        terminated=np.zeros((n, N), dtype=bool),
        truncated=np.zeros((n, N), dtype=bool),
        task_counts=np.zeros((n, N, len(TASK_EVENTS)), dtype=np.int32),
        elapsed=np.zeros(n, dtype=np.int64),
        crane_steps=np.zeros(n, dtype=np.int64),
        ended=np.zeros(n, dtype=bool),
    )
    return state, buffers


class TaskScratch(NamedTuple):
    """The task kernels' working arrays (one copy at a time)."""

    rows: np.ndarray  # (R, 4) int64: the reservation table (``table``)
    oracle: np.ndarray  # (4 P + 8,) int32: a search's distance oracle
    stop: np.ndarray  # (P,) bool: a search's stop poses
    cells: np.ndarray  # (L,) int64: a pick-up pose
    slots: np.ndarray  # (S,) int64: plan slots in order
    cranes: np.ndarray  # (N,) int64: components in transit, in index order
    parked: np.ndarray  # (N,) int64: those without a plan
    options: np.ndarray  # (K, 3) int64: a replan's (distance, target, goal) options
    order: np.ndarray  # (C,) int64: components to replan, oldest first
    joint: np.ndarray  # (N,) int64: the motion actions of a simulated step
    open_pairs: np.ndarray  # (P,) bool: tasks whose component and target are open
    comp_ok: np.ndarray  # (C,) bool
    target_ok: np.ndarray  # (C,) bool
    table: np.ndarray  # (C, 21 + N) float32: the components table
    first: np.ndarray  # (C,) int64: its components' first cells
    last: np.ndarray  # (C,) int64: and last cells
    claimable: np.ndarray  # (C,) int64: claimable components
    taken: np.ndarray  # (N,) int64: the components of the cranes' tasks
    free_target: np.ndarray  # (C,) bool
    best: np.ndarray  # (C,) float64: each component's shortest static path
    crane_rows: np.ndarray  # (N, 10) float32: the cranes table


def allocate_scratch(
    site: TaskSite, motion_site, n_cranes: int
) -> tuple[TaskScratch, SearchScratch]:
    """The working arrays of the task kernels and of their searches, room enough for any
    search (``max_expansions`` bounds the A*'s states: each expansion adds seven at most)."""
    C, L = motion_site.target_cells.shape
    N, P = n_cranes, len(site.task_comp)
    n = len(motion_site.static_occ)
    S, room = N + 1, path_room(site)
    rows = C * L + S * room * L + 8
    states = 1 + 7 * (site.max_expansions + 1)
    scratch = TaskScratch(
        rows=np.zeros((rows, 4), dtype=np.int64),
        oracle=np.zeros(4 * n + 8, dtype=np.int32),
        stop=np.zeros(n, dtype=bool),
        cells=np.zeros(L, dtype=np.int64),
        slots=np.zeros(S, dtype=np.int64),
        cranes=np.zeros(N, dtype=np.int64),
        parked=np.zeros(N, dtype=np.int64),
        options=np.zeros((motion_site.compatible.shape[1], 3), dtype=np.int64),
        order=np.zeros(C, dtype=np.int64),
        joint=np.zeros(N, dtype=np.int64),
        open_pairs=np.zeros(P, dtype=bool),
        comp_ok=np.zeros(C, dtype=bool),
        target_ok=np.zeros(C, dtype=bool),
        table=np.zeros((C, 21 + N), dtype=np.float32),
        first=np.zeros(C, dtype=np.int64),
        last=np.zeros(C, dtype=np.int64),
        claimable=np.zeros(C, dtype=np.int64),
        taken=np.zeros(N, dtype=np.int64),
        free_target=np.zeros(C, dtype=bool),
        best=np.zeros(C, dtype=np.float64),
        crane_rows=np.zeros((N, 10), dtype=np.float32),
    )
    search = search_scratch(n, rows, 2 * (states + 8), states + 1, room)
    return scratch, search
