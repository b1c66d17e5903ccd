"""The per-copy arrays of the motion mode: episode state and output buffers, leading axis ``B``.

``MotionState`` is ``multicrane.sim.state.SiteState`` of the multi-agent process for ``B``
copies, struct of arrays, plus the legality caches the simulator keeps (target readiness,
claimability), each copy's generator and its site events (``SiteEvents``: the episode's
schedule and what of it holds now); ``MotionBuffers`` holds what a step hands out
(observations ``[B, N, D]``, masks ``[B, N, A]``, rewards, flags, event counts) and the
kernels' scratch space. Both are allocated once and written in place; only the schedule's
interval tables grow when a drawn schedule needs more rows (``event_schedules``).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from multicrane.core.codes import CLAIM_BASE, SiteEventType
from multicrane.envs.infos import N_EVENT_TYPES
from multicrane.vector.motion_site import MotionSite
from multicrane.vector.paper_state import component_state, start_scratch


class MotionState(NamedTuple):
    """Every mutable value of ``B`` episodes (``C`` components, ``L`` cells each, ``N``
    cranes, ``P`` cells in the padded grid; -1 means "none")."""

    occ: np.ndarray  # (B, P) int8: FREE, WALL or component index + 1
    cells: np.ndarray  # (B, C, L) int32: each component's cells, node 1 first
    pickup: np.ndarray  # (B, C, L) int32: its pick-up pose (-1: pre-built)
    status: np.ndarray  # (B, C) int8: ``Status``
    moves: np.ndarray  # (B, C) int32: successful moves since the lift
    holder: np.ndarray  # (B, C) int16: the crane holding it
    filled: np.ndarray  # (B, C) int16: the target a component fills
    filled_by: np.ndarray  # (B, C) int16, per target: the component filling it
    held: np.ndarray  # (B, N) int64: each crane's component
    assembling: np.ndarray  # (B, N) int64: assembly steps left
    n_assembled: np.ndarray  # (B,) int64: assembled components, pre-built included
    step_count: np.ndarray  # (B,) int64
    target_ready: np.ndarray  # (B, C) bool: free, supports assembled
    has_ready: np.ndarray  # (B, C) bool: some compatible target is ready
    claimable: np.ndarray  # (B, C) bool: as handed out by the last observation
    pickup_in_zone: np.ndarray  # (B, N, C) bool: the pick-up pose lies in the crane's zone
    rng: np.ndarray  # (B, 5) uint64: each copy's PCG64 (``multicrane.vector.pcg64``)
    # -- site events (without them: all delivered, none down, nothing closed) --------------
    delivered: np.ndarray  # (B, C) bool: on site (else off site: not in ``occ``)
    down: np.ndarray  # (B, N) bool: the crane is broken down now
    closing: np.ndarray  # (B,) bool: some cell is closed now
    closed: np.ndarray  # (B, P) bool: the cells closed now ((B, 0) without events)
    arrival: np.ndarray  # (B, C) int64: the schedule's delivery steps
    outages: np.ndarray  # (B, K, 3) int64: the schedule's (crane, start, end) rows
    n_outages: np.ndarray  # (B,) int64
    closures: np.ndarray  # (B, K, 8) int64: (x0, y0, z0, x1, y1, z1, start, end) rows
    n_closures: np.ndarray  # (B,) int64
    next_change: np.ndarray  # (B,) int64: the next step an outage or closure starts or ends
    n_pending: np.ndarray  # (B,) int64: components not delivered yet


class MotionBuffers(NamedTuple):
    """What a step writes for the caller, and the kernels' scratch space."""

    obs: np.ndarray  # (B, N, D) float32, or uint8 in whole numbers (``obs_scale``)
    final_obs: np.ndarray  # (B, N, D): the last observation of an episode that just ended
    masks: np.ndarray  # (B, N, A) int8
    rewards: np.ndarray  # (B, N) float64
    terms: np.ndarray  # (B, N) float64: each crane's share of the team reward
    terminated: np.ndarray  # (B, N) bool
    truncated: np.ndarray  # (B, N) bool
    event_counts: np.ndarray  # (B, N, len(EventType)) int32: the step's events
    site_counts: np.ndarray  # (B, len(SiteEventType)) int32: the step's (or reset's) site events
    scheduling: np.ndarray  # (B,) bool: copies whose reset waits for its drawn schedule
    own_written: np.ndarray  # (B, N, W) int64: observation entries of the own planes set,
    # the component's plane in the first L, the targets' plane after
    own_count: np.ndarray  # (B, N, 2) int64: how many of them, per plane
    own_comp: np.ndarray  # (B, N) int64: the component the own planes show, -1 none
    order: np.ndarray  # (N,) int64 scratch: the step's crane order
    progress_by: np.ndarray  # (N,) int64 scratch: cranes that assembled, in order
    n_progress: np.ndarray  # (1,) int64 scratch: how many
    changed: np.ndarray  # (C,) bool scratch: components to repaint
    ready_changed: np.ndarray  # (1,) bool scratch: target readiness was refreshed
    closed_changed: np.ndarray  # (1,) bool scratch: the closed cells changed
    dirty: np.ndarray  # (X * Y,) bool scratch: plan columns to recompute
    dirty_list: np.ndarray  # (X * Y,) int64 scratch: the same as a list
    n_dirty: np.ndarray  # (1,) int64 scratch: its length
    tops: np.ndarray  # (7,) int64 scratch: a column's top heights per plane
    weights: np.ndarray  # (R,) float64 scratch: a candidate table's weights
    cdf: np.ndarray  # (R,) float64 scratch
    frames: np.ndarray  # (64, 3) int64 scratch: pairwise_sum's stack
    partial: np.ndarray  # (64,) float64 scratch: its partial sums
    occupied: np.ndarray  # (P,) bool scratch: cells taken while drawing a start
    chosen: np.ndarray  # (C,) int64 scratch: each component's start


def allocate(
    site: MotionSite, n: int, obs_dtype: Any = np.float32, observed: bool = True
) -> tuple[MotionState, MotionBuffers]:
    """Zeroed state and buffers for ``n`` copies of a compiled site (reset them before use),
    observations in ``obs_dtype`` (uint8: a site compiled in whole numbers); without
    ``observed`` (the task level observes by its own tables) no room for them."""
    C, L = site.target_cells.shape
    N = site.n_cranes
    D = site.obs_size if observed else 0
    XY = len(site.column_base)
    state = MotionState(
        **component_state(site, n),
        holder=np.full((n, C), -1, dtype=np.int16),
        held=np.full((n, N), -1, dtype=np.int64),
        assembling=np.zeros((n, N), dtype=np.int64),
        target_ready=np.zeros((n, C), dtype=bool),
        has_ready=np.zeros((n, C), dtype=bool),
        claimable=np.zeros((n, C), dtype=bool),
        pickup_in_zone=np.ones((n, N, C), dtype=bool),
        **_event_state(site, n),
    )
    buffers = MotionBuffers(
        obs=np.zeros((n, N, D), dtype=obs_dtype),
        final_obs=np.zeros((n, N, D), dtype=obs_dtype),
        masks=np.zeros((n, N, CLAIM_BASE + C), dtype=np.int8),
        rewards=np.zeros((n, N), dtype=np.float64),
        terms=np.zeros((n, N), dtype=np.float64),
        terminated=np.zeros((n, N), dtype=bool),
        truncated=np.zeros((n, N), dtype=bool),
        event_counts=np.zeros((n, N, N_EVENT_TYPES), dtype=np.int32),
        site_counts=np.zeros((n, len(SiteEventType)), dtype=np.int32),
        scheduling=np.zeros(n, dtype=bool),
        own_written=np.zeros((n, N, L * (1 + site.compatible.shape[1])), dtype=np.int64),
        own_count=np.zeros((n, N, 2), dtype=np.int64),
        own_comp=np.full((n, N), -1, dtype=np.int64),
        order=np.zeros(N, dtype=np.int64),
        progress_by=np.zeros(N, dtype=np.int64),
        n_progress=np.zeros(1, dtype=np.int64),
        changed=np.zeros(C, dtype=bool),
        ready_changed=np.zeros(1, dtype=bool),
        closed_changed=np.zeros(1, dtype=bool),
        dirty=np.zeros(XY, dtype=bool),
        dirty_list=np.zeros(XY, dtype=np.int64),
        n_dirty=np.zeros(1, dtype=np.int64),
        tops=np.zeros(7, dtype=np.int64),
        **start_scratch(site),
    )
    return state, buffers


def _event_state(site: MotionSite, n: int) -> dict[str, np.ndarray]:
    """The site-event fields of ``n`` copies: a static site's values (every component
    delivered, no crane down, nothing closed, no schedule) until a schedule is written."""
    C = len(site.length)
    return {
        "delivered": np.ones((n, C), dtype=bool),
        "down": np.zeros((n, site.n_cranes), dtype=bool),
        "closing": np.zeros(n, dtype=bool),
        "closed": np.zeros((n, len(site.static_occ) if site.has_events else 0), dtype=bool),
        "arrival": np.zeros((n, C), dtype=np.int64),
        "outages": np.zeros((n, 1, 3), dtype=np.int64),
        "n_outages": np.zeros(n, dtype=np.int64),
        "closures": np.zeros((n, 1, 8), dtype=np.int64),
        "n_closures": np.zeros(n, dtype=np.int64),
        "next_change": np.zeros(n, dtype=np.int64),
        "n_pending": np.zeros(n, dtype=np.int64),
    }
