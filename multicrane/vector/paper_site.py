"""The compiler: a one-crane scenario as the flat arrays the paper-mode kernels read.

``compile_site(scenario)`` turns what ``PaperAssemblyEnv`` builds from a scenario (its
``Site``, the start rule's candidate poses, the observation's static planes) into one
``PaperSite``: a named tuple of numpy arrays and numbers, shared by every copy and never
written. Cells are the ``Site``'s linear indices into the padded grid; ragged lists (a
component's cells, a target's supports) are padded with -1 and come with their lengths.

The vector env supports what the paper mode uses: one crane, the automatic process, no crane
reach; the scenario's site events are ignored, as ``PaperAssemblyEnv`` ignores them.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from multicrane.core.schema import Scenario
from multicrane.envs.paper_env import N_PAPER_CHANNELS
from multicrane.sim.site import WALL, Site
from multicrane.vector.start_arrays import component_arrays, grid_arrays

MAX_COMPONENTS = 126  # the occupancy grid is int8: component index + 1


class PaperSite(NamedTuple):
    """Everything the kernels read about a scenario (see the module doc)."""

    # -- the grid ---------------------------------------------------------------------------
    static_occ: np.ndarray  # (P,) int8: FREE or WALL (edges, ground, sky, obstacles)
    move_delta: np.ndarray  # (6,) int64: linear offset of each move
    column_of: np.ndarray  # (P,) int64: the plan index x * Y + y of a cell, -1 outside
    column_base: np.ndarray  # (X * Y,) int64: linear index of (x, y, 0)
    height: int  # H: cells z = 1..H of a column
    # -- components and targets (targets share the component indices) ----------------------
    length: np.ndarray  # (C,) int64: cells per component (and per own target)
    order: np.ndarray  # (n,) int64: the list order
    waits: np.ndarray  # (C,) bool: given out only while a compatible target is ready
    prebuilt: np.ndarray  # (C,) bool
    n_prebuilt: int
    target_cells: np.ndarray  # (C, L) int64, node 1 first, -1 padded
    target_at: np.ndarray  # (P,) int64: the target covering a cell, -1 none
    supports: np.ndarray  # (C, S) int64, -1 padded
    compatible: np.ndarray  # (C, K) int64: targets a component may fill, -1 padded
    # -- the start --------------------------------------------------------------------------
    prebuilt_on: np.ndarray  # (C, T) int64: targets a pre-built one may stand on, -1 padded
    fixed_cells: np.ndarray  # (C, L) int64: fixed start cells, -1 (none: pre-built or drawn)
    fixed_pickup: np.ndarray  # (C, L) int64: their pick-up cells
    fixed_occ: np.ndarray  # (P,) bool: cells of the fixed starts
    drawn: np.ndarray  # (D,) int64: components drawn at random, in list order
    table_of: np.ndarray  # (C,) int64: the candidate table of a drawn component, -1 none
    table_start: np.ndarray  # (n_tables + 1,) int64: rows of each table in the arrays below
    cand_cells: np.ndarray  # (R, L) int64: each candidate pose's cells
    cand_pickup: np.ndarray  # (R, L) int64: its pick-up pose's cells
    cand_prob: np.ndarray  # (R,) float64: its probability under the rule
    # -- rules and reward -------------------------------------------------------------------
    step_limit: int
    move_limit: int
    completion: float
    over_limit_cost: float
    step_cost: float
    # -- observation ------------------------------------------------------------------------
    obs_template: np.ndarray  # (X * Y * 6,) float32: targets (0, 3) and obstacles (1)


def compile_site(scenario: Scenario) -> PaperSite:
    """The arrays of a one-crane scenario (ValueError for what the kernels do not model)."""
    if scenario.crane_specs:
        raise ValueError(f"{scenario.name}: the vector env does not model crane reach")
    if scenario.n_components > MAX_COMPONENTS:
        raise ValueError(f"{scenario.name}: at most {MAX_COMPONENTS} components in the vector env")
    site = Site(scenario)
    X, Y, H = scenario.size
    return PaperSite(
        **grid_arrays(site, X, Y, H),
        order=np.array(scenario.order, dtype=np.int64),
        **component_arrays(scenario, site),
        step_limit=scenario.step_limit,
        move_limit=scenario.reward.move_limit,
        completion=float(scenario.reward.completion),
        over_limit_cost=float(scenario.reward.over_limit_cost),
        step_cost=float(scenario.reward.step_cost),
        obs_template=_obs_template(site, X, Y, H),
    )


def _obs_template(site: Site, X: int, Y: int, H: int) -> np.ndarray:
    """The planes that no component changes: target marks and heights (channels 0 and 3) and
    the obstacles' top heights (channel 1, which initial components may raise)."""
    planes = np.zeros((X, Y, N_PAPER_CHANNELS), dtype=np.float32)
    for cells in site.target_cells:
        for j in cells:
            x, y, z = site.cell(j)
            planes[x, y, 0] = 1.0
            planes[x, y, 3] = max(planes[x, y, 3], z)
    grid = site.static.reshape(site.shape)[1 : X + 1, 1 : Y + 1, 1 : H + 1]
    z = np.arange(1, H + 1, dtype=np.float32)
    planes[:, :, 1] = ((grid == WALL) * z).max(axis=2)
    return planes.reshape(-1)

