"""The per-copy arrays of the paper mode: episode state and output buffers, leading axis ``B``.

``PaperState`` is the state of ``docs/paper-spec.md`` section 5 for ``B`` copies, struct of
arrays (the fields of ``multicrane.sim.state.SiteState`` that one crane in the automatic
process uses, plus each copy's generator); ``PaperBuffers`` holds what a step hands out
(observations, masks, rewards, flags, infos) and the kernels' scratch space. Both are
allocated once, written in place by the kernels, and never reallocated. ``component_state``
and ``start_scratch`` allocate the fields the motion mode's arrays share with these.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from multicrane.core.codes import N_MOVES
from multicrane.envs.infos import N_EVENT_TYPES
from multicrane.vector.paper_site import PaperSite
from multicrane.vector.pcg64 import PAIRWISE_DEPTH, RNG_WORDS


class PaperState(NamedTuple):
    """Every mutable value of ``B`` episodes (``C`` components, ``L`` cells each, ``P`` cells
    in the padded grid; -1 means "none")."""

    occ: np.ndarray  # (B, P) int8: FREE, WALL or component index + 1
    cells: np.ndarray  # (B, C, L) int32: each component's cells, node 1 first
    pickup: np.ndarray  # (B, C, L) int32: its pick-up pose (-1: pre-built)
    status: np.ndarray  # (B, C) int8: ``Status``
    moves: np.ndarray  # (B, C) int32: successful moves since the lift (m)
    filled: np.ndarray  # (B, C) int16: the target a component fills
    filled_by: np.ndarray  # (B, C) int16, per target: the component filling it
    passed_over: np.ndarray  # (B, C) bool: a pre-built entry's pass-over has happened
    held: np.ndarray  # (B,) int64: the current component
    pass_over: np.ndarray  # (B,) bool: the next step is a pass-over
    pointer: np.ndarray  # (B,) int64: the list pointer
    n_assembled: np.ndarray  # (B,) int64: arrived components, pre-built included (N)
    step_count: np.ndarray  # (B,) int64
    rng: np.ndarray  # (B, 5) uint64: each copy's PCG64 (``multicrane.vector.pcg64``)


class PaperBuffers(NamedTuple):
    """What a step writes for the caller, and the kernels' scratch space."""

    obs: np.ndarray  # (B, D) float32 or uint8: the observations
    final_obs: np.ndarray  # (B, D): the last observation of an episode that just ended
    masks: np.ndarray  # (B, 6) int8
    rewards: np.ndarray  # (B,) float64
    terminated: np.ndarray  # (B,) bool
    truncated: np.ndarray  # (B,) bool
    event_counts: np.ndarray  # (B, len(EventType)) int32: the step's events
    component_index: np.ndarray  # (B,) int64: the component the next action moves, -1 none
    weights: np.ndarray  # (R,) float64 scratch: a candidate table's weights
    cdf: np.ndarray  # (R,) float64 scratch
    frames: np.ndarray  # (64, 3) int64 scratch: pairwise_sum's stack
    partial: np.ndarray  # (64,) float64 scratch: its partial sums
    occupied: np.ndarray  # (P,) bool scratch: cells taken while drawing a start
    chosen: np.ndarray  # (C,) int64 scratch: each component's start (candidate row or target)
    touched: np.ndarray  # (2 L,) int64 scratch: plan columns a step changed


def allocate(site: PaperSite, n: int, obs_dtype=np.float32) -> tuple[PaperState, PaperBuffers]:
    """Zeroed state and buffers for ``n`` copies of a compiled site (reset them before use)."""
    C, L = site.target_cells.shape
    D = len(site.obs_template)
    state = PaperState(
        **component_state(site, n),
        passed_over=np.zeros((n, C), dtype=bool),
        held=np.full(n, -1, dtype=np.int64),
        pass_over=np.zeros(n, dtype=bool),
        pointer=np.zeros(n, dtype=np.int64),
    )
    buffers = PaperBuffers(
        obs=np.zeros((n, D), dtype=obs_dtype),
        final_obs=np.zeros((n, D), dtype=obs_dtype),
        masks=np.ones((n, N_MOVES), dtype=np.int8),
        rewards=np.zeros(n, dtype=np.float64),
        terminated=np.zeros(n, dtype=bool),
        truncated=np.zeros(n, dtype=bool),
        event_counts=np.zeros((n, N_EVENT_TYPES), dtype=np.int32),
        component_index=np.full(n, -1, dtype=np.int64),
        **start_scratch(site),
        touched=np.zeros(2 * L, dtype=np.int64),
    )
    return state, buffers


def component_state(site, n: int) -> dict[str, np.ndarray]:
    """The state fields both modes keep for ``n`` copies: the grid, every component's cells,
    pick-up pose, status, moves and target, the counts and each copy's generator."""
    C, L = site.target_cells.shape
    return {
        "occ": np.zeros((n, len(site.static_occ)), dtype=np.int8),
        "cells": np.full((n, C, L), -1, dtype=np.int32),
        "pickup": np.full((n, C, L), -1, dtype=np.int32),
        "status": np.zeros((n, C), dtype=np.int8),
        "moves": np.zeros((n, C), dtype=np.int32),
        "filled": np.full((n, C), -1, dtype=np.int16),
        "filled_by": np.full((n, C), -1, dtype=np.int16),
        "n_assembled": np.zeros(n, dtype=np.int64),
        "step_count": np.zeros(n, dtype=np.int64),
        "rng": np.zeros((n, RNG_WORDS), dtype=np.uint64),
    }


def start_scratch(site) -> dict[str, np.ndarray]:
    """The scratch buffers of the start-drawing kernel (``paper_reset.draw_start``)."""
    rows = max(int(np.diff(site.table_start).max(initial=0)), 1)
    return {
        "weights": np.zeros(rows, dtype=np.float64),
        "cdf": np.zeros(rows, dtype=np.float64),
        "frames": np.zeros((PAIRWISE_DEPTH, 3), dtype=np.int64),
        "partial": np.zeros(PAIRWISE_DEPTH, dtype=np.float64),
        "occupied": np.zeros(len(site.static_occ), dtype=bool),
        "chosen": np.zeros(len(site.prebuilt), dtype=np.int64),
    }


def nbytes(arrays: NamedTuple) -> int:
    """Bytes held by the arrays of a state or buffers tuple."""
    return sum(a.nbytes for a in arrays)
