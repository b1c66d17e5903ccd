"""The observation builder: one flat float32 vector per crane, fixed shape per scenario.

Layout (``ObservationLayout``, ``multicrane.envs.observation_layout``, gives the slices;
``split`` undoes the flattening):

1. ``planes``: an (X, Y, 9) array over the site's plan, channel last. Each channel holds the
   height of the highest qualifying cell above (x, y), divided by the site height (0 = none):

   ==  ===========================================================================
   0   obstacles
   1   components in the yard (initial)
   2   components ready to pick up (claimable now; in automatic mode: assigned)
   3   components in transit
   4   components at their target (arrived or assembled, pre-built included)
   5   free targets
   6   components in transit past the move limit
   7   this crane's component
   8   targets this crane's component could fill now (free, compatible, supported)
   ==  ===========================================================================

2. ``components``: a (C, 14) table in scenario order (claim action ``8 + i`` names row i):
   status one-hot (4), ready, held by a crane, held by this crane, is a beam (its kind's
   ``beam_feature``, ``multicrane.core.kinds``: every kind shares the planes), node 1 and
   node 2 as (x, y, z) divided by the site size (a panel: two opposite corners of its box).
3. ``crane``: 9 values: holds a component, it is in transit, it has arrived, its moves /
   move limit (clipped to 1), past the move limit, assembly steps left / assembly steps,
   pass-over pending, fraction of components assembled, fraction of the step limit used.

4. ``events`` (only when the simulator has site events, ``multicrane.sim.events``; so without
   them the spaces are as before): per component ``delivered`` (C), per crane ``available``
   (N, not broken down) and the ``closed`` plan (X, Y: the height of the highest closed cell
   above (x, y), divided by the site height). A component not yet delivered is not drawn in
   the planes and its table row is all zero: only its ``delivered`` 0 is known.

Channels 0-6 are shared by all cranes and kept up to date incrementally: each cell carries
one bit per channel (``multicrane.envs.plane_grid``), and only the plane entries whose bits
changed are rewritten each step. One policy can act for every crane: all per-crane facts are in
channels 7-8, the "held by this crane" column and the crane vector.
"""

from __future__ import annotations

import struct

import numpy as np

from multicrane.core.codes import Status
from multicrane.core.kinds import kind_spec
from multicrane.envs.observation_layout import (
    COMPONENT_FEATURES,
    CRANE_FEATURES,
    MINE,
    MY_TARGETS,
    N_OWN,
    ObservationLayout,
)
from multicrane.envs.plane_grid import (
    ANY_TARGET,
    AT_TARGET,
    FREE_TARGET,
    HEIGHT,
    IN_TRANSIT,
    INITIAL,
    MARK,
    N_SHARED,
    OBSTACLE,
    OVER_LIMIT,
    READY,
    PlaneGrid,
    PlaneSpec,
)
from multicrane.sim.simulator import NOBODY, WALL, Simulator

_INITIAL, _IN_TRANSIT, _ARRIVED, _ASSEMBLED = (int(s) for s in Status)


# A component table row and a crane vector, packed straight into an observation's buffer.
_ROW = struct.Struct(f"{COMPONENT_FEATURES}f")
_CRANE = struct.Struct(f"{CRANE_FEATURES}f")
_NOT_HOLDING = (0.0,) * 5

MULTI_AGENT_PLANES = PlaneSpec(tuple(1 << b for b in range(N_SHARED)), (HEIGHT,) * N_SHARED, True)


class Observer:
    """Builds every crane's observation from a Simulator's public state, updating only what
    changed (the environment hands it ``Simulator.take_changed()``); it never writes to it."""

    def __init__(self, sim: Simulator, planes: PlaneSpec = MULTI_AGENT_PLANES):
        self.sim = sim
        X, Y, H = sim.scenario.size
        self.plan = (X, Y)
        self.height = H
        self.spec = planes
        self._events = sim.events is not None
        self.layout = lay = ObservationLayout(
            (X, Y), sim.site.n_components, planes.n, sim.n_cranes if self._events else 0
        )
        self._grid = PlaneGrid(sim.site, planes)
        self._own_start = lay.own.start
        self._components_start = lay.components.start
        self._crane_start = lay.crane.start
        # Per padded linear cell index: its (x, y) plan index (-1 outside the site, the
        # ground and the sky included) and its height divided by the site height.
        xy = np.full(sim.site.shape, -1, dtype=np.int64)
        xy[1 : X + 1, 1 : Y + 1, 1 : H + 1] = np.arange(X * Y).reshape(X, Y, 1)
        z = np.broadcast_to(np.arange(H + 2), sim.site.shape).reshape(-1).tolist()
        self._column = list(zip(xy.reshape(-1).tolist(), [v / H for v in z], strict=True))
        # Per padded linear cell index: (x, y, z) divided by the site size (the table's nodes).
        scale = (1.0 / max(X - 1, 1), 1.0 / max(Y - 1, 1), 1.0 / H)
        self._scaled = [
            tuple(v * f for v, f in zip(sim.site.cell(j), scale, strict=True))
            for j in range(int(np.prod(sim.site.shape)))
        ]
        self._target_footprint = [self._footprint(cells) for cells in sim.site.target_cells]
        # Per component, as last computed: (its cells, its MINE plane entries) and (the
        # simulator's ``targets_version``, its MY_TARGETS plane entries), (index, value) each.
        self._mine: dict[int, tuple[list[int], list[tuple[int, float]]]] = {}
        self._my_targets: dict[int, tuple[int, list[tuple[int, float]]]] = {}
        self._assembly_steps, self._move_limit = sim.scenario.assembly_steps, sim.site.move_limit
        self._limit = max(self._move_limit, 1)
        self._beam = [float(kind_spec(k).beam_feature) for k in sim.site.kind]
        self._n_components = sim.site.n_components

    def __getstate__(self) -> dict:
        # Two views into the template and a memoryview of it: rebuilt on unpickling (a
        # copied view would no longer share the template's memory).
        state = self.__dict__.copy()
        for name in ("planes", "table", "_shared"):
            state.pop(name, None)
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        if "template" in state:
            self._bind_views()

    def _bind_views(self) -> None:
        X, Y = self.plan
        self.planes = self.template[self.layout.shared].reshape(X * Y, self.spec.n)
        self.table = self.template[self.layout.components].reshape(-1, COMPONENT_FEATURES)
        self._shared = memoryview(self.template)[self.layout.shared]

    def _footprint(self, cells: list[int]) -> list[tuple[int, float]]:
        """(plan index, top height / H) of each (x, y) column a set of cells covers."""
        column = self._column
        top: dict[int, float] = {}
        for j in cells:
            p, z = column[j]
            if z > top.get(p, 0.0):
                top[p] = z
        return list(top.items())

    # -- the shared part -------------------------------------------------------------------

    def reset(self, step_limit: int) -> None:
        sim = self.sim
        self.step_limit = step_limit
        # The shared planes and the component table are views into the template, which
        # every crane's observation starts as a copy of.
        self.template = np.zeros(self.layout.size, dtype=np.float32)
        self._bind_views()
        grid = self._grid
        grid.reset()
        obstacles = np.flatnonzero(sim.site.static == WALL).tolist()
        grid.paint(obstacles, 0, 1 << OBSTACLE)
        self._painted: list[tuple[list[int], int]] = [([], 0)] * sim.site.n_components
        self._targets_free = [True] * sim.site.n_components
        for t in range(sim.site.n_components):
            grid.paint([], 0, (1 << FREE_TARGET) | (1 << ANY_TARGET), sim.site.target_cells[t])
        self._ready: set[int] = set()
        self._closed_seen = None

    def _component_bits(self, c: int, status: int, ready: bool) -> int:
        if status == _INITIAL:
            return (1 << INITIAL) | ((1 << READY) if ready else 0)
        if status == _IN_TRANSIT:
            over = (1 << OVER_LIMIT) if self.sim.views.moves[c] > self._move_limit else 0
            return (1 << IN_TRANSIT) | over
        return 1 << AT_TARGET

    def _paint_component(self, c: int, ready: bool) -> None:
        """Paint a cleared component where it is now, and its table row."""
        sim = self.sim
        views = sim.views
        cells, status = sim.state.cells[c], views.status[c]
        bits = self._component_bits(c, status, ready)
        if not views.delivered[c]:  # off site: nothing of it is known but that
            cells, bits = [], 0
        self._grid.paint([], 0, bits, cells)
        self._painted[c] = (cells, bits)
        offset = (self._components_start + c * COMPONENT_FEATURES) * 4
        if not cells:
            _ROW.pack_into(self.template, offset, *(0.0,) * COMPONENT_FEATURES)
            return
        # The component table row (the "held by this crane" column is per crane).
        _ROW.pack_into(
            self.template,
            offset,
            status == _INITIAL, status == _IN_TRANSIT, status == _ARRIVED, status == _ASSEMBLED,
            ready,
            views.holder[c] != NOBODY,
            0.0,
            self._beam[c],
            *self._scaled[cells[0]],
            *self._scaled[cells[-1]],
        )  # fmt: skip

    def update(self, changed: set[int], ready: list[int], full: bool = False) -> None:
        """Bring the shared part up to date after a reset or a step.

        ``changed``: the components whose cells or status changed (``Simulator.take_changed``;
        every component after a reset); ``ready``: the components to mark ready; ``full``:
        repaint every component whatever ``changed`` says. Reads the simulator, changes nothing.
        """
        sim = self.sim
        ready_now = set(ready)
        if full:
            changed = set(range(sim.site.n_components))
        else:
            changed = changed | (ready_now ^ self._ready)
        self._ready = ready_now
        filled, target_cells = sim.views.filled, sim.site.target_cells
        grid, painted = self._grid, self._painted
        # Every old cell is cleared before any new one is painted: a component may move into
        # a cell another one left in the same step.
        for c in changed:
            grid.paint(*painted[c], 0)
        for c in changed:
            self._paint_component(c, c in ready_now)
            t = filled[c]  # a target is filled only when a component arrives at it
            if t >= 0 and self._targets_free[t]:
                grid.paint(target_cells[t], 1 << FREE_TARGET, 0)
                self._targets_free[t] = False
        grid.refresh(self._shared)
        if self._events:
            self._update_events()

    def _update_events(self) -> None:
        """The events block: delivered flags, available cranes, the closed plan."""
        sim, lay, C = self.sim, self.layout, self.sim.site.n_components
        ev = self.template[lay.events]
        ev[:C] = sim.state.delivered
        ev[C : C + sim.n_cranes] = [sim.crane_up(k) for k in range(sim.n_cranes)]
        if sim.closed is not self._closed_seen:  # replaced whenever the closures change
            self._closed_seen = sim.closed
            X, Y = self.plan
            closed = sim.closed.reshape(sim.site.shape)[1 : X + 1, 1 : Y + 1, 1 : self.height + 1]
            z = np.arange(1, self.height + 1, dtype=np.float32) / self.height
            ev[C + sim.n_cranes :] = (closed * z).max(axis=2).reshape(-1)

    # -- per crane ---------------------------------------------------------------------------

    def _targets_plane(self, targets: list[int]) -> list[tuple[int, float]]:
        """(observation index, value) of the MY_TARGETS plane entries for a set of targets."""
        top: dict[int, float] = {}
        for t in targets:
            for p, z in self._target_footprint[t]:
                top[p] = max(top.get(p, 0.0), z)
        return [(self._own_start + p * N_OWN + 1, z) for p, z in top.items()]

    def observe(self, crane: int) -> np.ndarray:
        """A fresh array (the caller may keep it) with this crane's observation."""
        obs = self.template.copy()
        self._write_own(self._own_entries(crane), memoryview(obs), 0)
        return obs

    def observe_all(self) -> np.ndarray:
        """Every crane's observation as the rows of one fresh (cranes, size) array: the
        shared part is written into all rows by one broadcast copy of the template, then
        each row gets its crane's own entries; row i equals ``observe(i)``."""
        self._last_own = [self._own_entries(crane) for crane in range(self.sim.n_cranes)]
        return self.last_rows()

    def last_rows(self, out: np.ndarray | None = None) -> np.ndarray:
        """The rows ``observe_all`` last returned, built again (into ``out`` when given, else
        a fresh array; equal to them as they were returned, until the next ``update``: the
        template and each crane's own entries as then computed)."""
        size = self.layout.size
        if out is None:
            out = np.empty((len(self._last_own), size), dtype=np.float32)
        out[:] = self.template
        flat = memoryview(out.reshape(-1))
        for crane, own in enumerate(self._last_own):
            self._write_own(own, flat, crane * size)
        return out

    def _own_entries(self, crane: int) -> tuple:
        """This crane's own entries: (index, value) of its MINE and MY_TARGETS plane entries,
        the index of its "held by this crane" table entry (-1: none) and its crane vector."""
        sim = self.sim
        st = sim.state
        comp = st.held[crane]
        if comp != NOBODY:
            cells = st.cells[comp]
            mine = self._mine.get(comp)
            if mine is None or mine[0] != cells:
                own = self._own_start
                mine = (cells, [(own + p * N_OWN, z) for p, z in self._footprint(cells)])
                self._mine[comp] = mine
            version = sim.targets_version
            targets = self._my_targets.get(comp)
            if targets is None or targets[0] != version:
                targets = (version, self._targets_plane(sim.ready_targets(comp)))
                self._my_targets[comp] = targets
            flag = self._components_start + comp * COMPONENT_FEATURES + 6
            status = sim.views.status[comp]
            moves = sim.views.moves[comp]
            held = (1.0, status == _IN_TRANSIT, status == _ARRIVED,
                    min(moves / self._limit, 1.0), moves > self._move_limit)  # fmt: skip
            entries = (mine[1], targets[1], flag)
        else:
            held, entries = _NOT_HOLDING, ((), (), -1)
        vector = (
            *held,
            st.assembling[crane] / self._assembly_steps,
            st.pass_over[crane],
            st.n_assembled / self._n_components,
            min(st.step_count / self.step_limit, 1.0),
        )
        return (*entries, vector)

    def _write_own(self, own: tuple, obs: memoryview, base: int) -> None:
        """Write a crane's own entries (``_own_entries``) into ``obs[base:base + size]`` (flat
        float32 holding a copy of the template there)."""
        mine, targets, flag, vector = own
        for i, v in mine:
            obs[base + i] = v
        for i, v in targets:
            obs[base + i] = v
        if flag >= 0:
            obs[base + flag] = 1.0
        _CRANE.pack_into(obs, (base + self._crane_start) * 4, *vector)


# The plane constants and PlaneSpec live in plane_grid, the layout in observation_layout;
# they are part of this module's face.
__all__ = ["ANY_TARGET", "AT_TARGET", "FREE_TARGET", "HEIGHT", "IN_TRANSIT", "INITIAL", "MARK",
           "OBSTACLE", "OVER_LIMIT", "READY", "COMPONENT_FEATURES", "CRANE_FEATURES", "MINE",
           "MULTI_AGENT_PLANES", "MY_TARGETS", "N_OWN", "N_SHARED", "ObservationLayout",
           "Observer", "PlaneSpec"]  # fmt: skip
