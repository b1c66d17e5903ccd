"""The static site of a scenario: padded grid, coordinates, targets and their supports.

A ``Site`` is built once per scenario and never changes afterwards; every episode's mutable
state (``multicrane.sim.state.SiteState``) refers to it by linear cell index.

Occupancy is one ``int16`` grid padded by a wall on every side (index ``x + 1, y + 1, z``;
layer ``z = 0`` is the ground and layer ``height + 1`` the sky, both walls). A cell holds
``FREE``, ``WALL`` (wall, ground or obstacle) or ``component index + 1``. Linear indices
address the flattened grid; a move adds one constant (``move_delta[m]``) to each of a
component's cell indices.
"""

from __future__ import annotations

import numpy as np

from multicrane.core.codes import CLAIM_BASE, MOVE_DELTAS
from multicrane.core.kinds import STACKED, kind_spec, waits_for_target
from multicrane.core.schema import Scenario
from multicrane.sim import geometry

FREE = 0
WALL = -1
NOBODY = -1


class Site:
    """Everything about a scenario's site that no episode changes.

    Targets share the component indices (target ``t`` is component ``t``'s own target).
    Attributes (all read-only by convention):

    - ``shape``: (X + 2, Y + 2, H + 2), the padded grid; ``size``: its number of cells.
    - ``static``: (size,) int16, the empty padded grid (``FREE`` inside, ``WALL`` elsewhere).
    - ``move_delta``: the linear-index offset of each of the six moves.
    - ``kind``, ``length``: per component, its ``Kind`` (as int) and its number of cells;
      ``waits``: it may be claimed only while a target it may fill is ready (beams, panels).
    - ``target_cells``: per target, its cells as linear indices (node 1 first);
      ``target_cellset``: the same as frozensets.
    - ``target_supports``: per target, the targets that must hold assembled components
      before it can be filled.
    - ``compatible``: per component, the targets it may fill.
    - ``target_at``: (size,) int16, the target covering each cell (``NOBODY`` if none).
    - ``reach``: ``None`` when every crane reaches everywhere, else one (size,) bool array
      per crane the scenario describes (``Scenario.crane_specs``): the cells it reaches.
    """

    def __init__(self, scenario: Scenario):
        self.scenario = scenario
        X, Y, H = scenario.size
        self.shape = (X + 2, Y + 2, H + 2)
        self.size = int(np.prod(self.shape))
        self._sx = (Y + 2) * (H + 2)
        self._sy = H + 2
        self.move_delta = [dx * self._sx + dy * self._sy + dz for dx, dy, dz in MOVE_DELTAS]
        comps = scenario.components
        self.n_components = len(comps)
        self.n_actions = CLAIM_BASE + self.n_components
        self.kind = [int(c.kind) for c in comps]
        self.waits = [waits_for_target(c.kind) for c in comps]
        self.length = [c.length for c in comps]
        self.move_limit = scenario.reward.move_limit
        self.target_cells = [self.lin_pose(c.target) for c in comps]
        self.target_cellset = [frozenset(t) for t in self.target_cells]
        self.target_supports = self._target_supports()
        self.compatible = [self._compatible_targets(i) for i in range(self.n_components)]
        self.target_at = np.full(self.size, NOBODY, dtype=np.int16)
        for t, cells in enumerate(self.target_cells):
            self.target_at[cells] = t
        self.static = self._static_grid().reshape(-1)
        self.reach = self._reach() if scenario.crane_specs else None

    # -- reach -----------------------------------------------------------------------------

    def reaches(self, crane: int, cells) -> bool:
        """True when ``crane`` reaches every cell (linear indices); always without reach."""
        if self.reach is None:
            return True
        zone = self.reach[crane]
        return all(zone[j] for j in cells)

    def _reach(self) -> list[np.ndarray]:
        """Each crane's zone: padded cells whose column lies within its radius of its base."""
        X, Y, _ = self.scenario.size
        xs = np.arange(-1, X + 1)[:, None]  # padded index -> site coordinate
        ys = np.arange(-1, Y + 1)[None, :]
        zones = []
        for spec in self.scenario.crane_specs:
            bx, by = spec.base
            columns = (xs - bx) ** 2 + (ys - by) ** 2 <= spec.radius**2
            zone = np.broadcast_to(columns[:, :, None], self.shape)
            zones.append(np.ascontiguousarray(zone).reshape(-1))
        return zones

    # -- coordinates ---------------------------------------------------------------------

    def lin(self, x: int, y: int, z: int) -> int:
        """Linear index of site cell (x, y, z) in the padded grid."""
        return (x + 1) * self._sx + (y + 1) * self._sy + z

    def cell(self, index: int) -> tuple[int, int, int]:
        """Site cell (x, y, z) of a linear index."""
        px, rest = divmod(index, self._sx)
        py, z = divmod(rest, self._sy)
        return (px - 1, py - 1, z)

    def grid_coords(self, cells=None) -> np.ndarray:
        """(len(cells), 3) int64: the padded grid coordinates of linear indices (every cell's
        when ``cells`` is None): ``Site.cell`` + (1, 1, 0), so differences are the same."""
        if cells is None:
            cells = np.arange(self.size)
        return np.stack(np.unravel_index(cells, self.shape), axis=1).astype(np.int64)

    def lin_pose(self, pose: geometry.Pose) -> list[int]:
        """The linear indices of a pose's cells, from node 1 to node 2."""
        return [self.lin(*c) for c in geometry.pose_cells(*pose)]

    # -- construction ----------------------------------------------------------------------

    def _static_grid(self) -> np.ndarray:
        grid = np.full(self.shape, WALL, dtype=np.int16)
        X, Y, H = self.scenario.size
        grid[1 : X + 1, 1 : Y + 1, 1 : H + 1] = FREE
        for box in self.scenario.obstacles:
            (x0, y0, z0), (x1, y1, z1) = box.lo, box.hi
            grid[x0 + 1 : x1 + 2, y0 + 1 : y1 + 2, z0 : z1 + 1] = WALL
        return grid

    def _compatible_targets(self, comp: int) -> list[int]:
        """Targets a component may fill: its own, or with interchangeable targets every
        target of the same kind and shape (``geometry.shape_key``). A lifted component keeps the
        orientation of its own target (there is no rotation move), so a target of another
        orientation could never be filled; leaving it out keeps masks and skips honest."""
        comps = self.scenario.components
        if not self.scenario.interchangeable_targets:
            return [comp]
        own = comps[comp]
        shape = geometry.shape_key(own.kind, own.target)
        return [
            j
            for j, other in enumerate(comps)
            if geometry.shape_key(other.kind, other.target) == shape
        ]

    def _target_supports(self) -> list[list[int]]:
        """Targets that must hold assembled components before this target can be filled.

        Beams and panels name theirs (the loader derives a panel's); a target of a stacked
        kind (``multicrane.core.kinds``: a column) standing on another target needs that one.
        """
        supports = []
        for c in self.scenario.components:
            if kind_spec(c.kind).supports != STACKED:
                supports.append(list(c.supports))
                continue
            bottom = min(geometry.pose_cells(*c.target), key=lambda cell: cell[2])
            below = self.lin(bottom[0], bottom[1], bottom[2] - 1)
            supports.append([t for t, cells in enumerate(self.target_cells) if below in cells])
        return supports
