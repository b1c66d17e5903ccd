"""The observation builder: one flat float32 vector per crane, fixed shape per scenario.

Layout (``ObservationLayout`` gives the slices; ``split`` undoes the flattening):

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

Channels 0-6 are shared by all cranes and kept up to date incrementally: a ``uint8`` bit grid
holds one bit per channel per cell, and only the (x, y) columns whose bits changed are
recomputed each step. One policy can act for every crane: all per-crane facts are in
channels 7-8, the "held by this crane" column and the crane vector.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from multicrane.core.codes import Status
from multicrane.core.kinds import kind_spec
from multicrane.sim.simulator import NOBODY, WALL, Simulator

_INITIAL, _IN_TRANSIT, _ARRIVED, _ASSEMBLED = (int(s) for s in Status)

N_SHARED = 7
N_OWN = 2
COMPONENT_FEATURES = 14
CRANE_FEATURES = 9

# Bits of the cell grid; the first seven are also the shared channels, in this order.
OBSTACLE, INITIAL, READY, IN_TRANSIT, AT_TARGET, FREE_TARGET, OVER_LIMIT = range(N_SHARED)
ANY_TARGET = 7  # a target cell, free or filled (never changes)
MINE, MY_TARGETS = N_SHARED, N_SHARED + 1

HEIGHT, MARK = 0, 1  # what a plane holds: the top cell's height, or 1 where any cell qualifies


@dataclass(frozen=True)
class PlaneSpec:
    """Which plan-view planes an Observer keeps: per plane, the grid bits that qualify a
    cell, and whether it holds the top height (``HEIGHT``) or a 0/1 mark (``MARK``)."""

    masks: tuple[int, ...]
    values: tuple[int, ...]
    normalise: bool  # heights divided by the site height

    @property
    def n(self) -> int:
        return len(self.masks)


MULTI_AGENT_PLANES = PlaneSpec(tuple(1 << b for b in range(N_SHARED)), (HEIGHT,) * N_SHARED, True)


@dataclass(frozen=True)
class ObservationLayout:
    """Where each part lies in the flat observation vector."""

    plan: tuple[int, int]  # (X, Y)
    n_components: int
    n_shared: int = N_SHARED
    n_cranes: int = 0  # > 0: the events block is present (see the module doc)

    @property
    def shared(self) -> slice:
        return slice(0, self.plan[0] * self.plan[1] * self.n_shared)

    @property
    def own(self) -> slice:
        start = self.shared.stop
        return slice(start, start + self.plan[0] * self.plan[1] * N_OWN)

    @property
    def components(self) -> slice:
        start = self.own.stop
        return slice(start, start + self.n_components * COMPONENT_FEATURES)

    @property
    def crane(self) -> slice:
        start = self.components.stop
        return slice(start, start + CRANE_FEATURES)

    @property
    def clock(self) -> slice:
        """The crane vector's last value: the fraction of the step limit used."""
        return slice(self.crane.stop - 1, self.crane.stop)

    @property
    def events(self) -> slice:
        start = self.crane.stop
        n = self.n_components + self.n_cranes + self.plan[0] * self.plan[1] if self.n_cranes else 0
        return slice(start, start + n)

    @property
    def size(self) -> int:
        return self.events.stop

    def split(self, obs: np.ndarray) -> dict[str, np.ndarray]:
        """The flat vector as ``planes`` (X, Y, 9), ``components`` (C, 14) and ``crane`` (9,)."""
        X, Y = self.plan
        planes = np.concatenate(
            [obs[self.shared].reshape(X, Y, N_SHARED), obs[self.own].reshape(X, Y, N_OWN)],
            axis=-1,
        )
        out = {
            "planes": planes,
            "components": obs[self.components].reshape(self.n_components, COMPONENT_FEATURES),
            "crane": obs[self.crane],
        }
        if self.n_cranes:
            ev = obs[self.events]
            C, N = self.n_components, self.n_cranes
            out["delivered"] = ev[:C]
            out["available"] = ev[C : C + N]
            out["closed"] = ev[C + N :].reshape(X, Y)
        return out


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
        self._own_start = lay.own.start
        self._components_start = lay.components.start
        self._crane = lay.crane
        # Per padded linear cell index: the (x, y) plan index and the index of its bit byte
        # (-1 outside the site, the ground and the sky included).
        xy = np.full(sim.site.shape, -1, dtype=np.int64)
        xy[1 : X + 1, 1 : Y + 1, 1 : H + 1] = np.arange(X * Y).reshape(X, Y, 1)
        z = np.broadcast_to(np.arange(H + 2), sim.site.shape)
        self._xy = xy.reshape(-1).tolist()
        self._z = z.reshape(-1).tolist()
        self._byte = np.where(xy >= 0, xy * (H + 1) + z, -1).reshape(-1).tolist()
        # Column refresh: plane f of a column is max over z of value[z, f] * (bits & mask[f]).
        self._masks = np.array(planes.masks, dtype=np.uint8).reshape(1, 1, planes.n)
        z_value = np.arange(H + 1, dtype=np.float32) / (H if planes.normalise else 1)
        self._values = np.stack(
            [z_value if v == HEIGHT else (z_value > 0).astype(np.float32) for v in planes.values],
            axis=1,
        ).reshape(1, H + 1, planes.n)
        # Per padded linear cell index: (x, y, z) divided by the site size (the table's nodes).
        scale = (1.0 / max(X - 1, 1), 1.0 / max(Y - 1, 1), 1.0 / H)
        self._scaled = [
            tuple(v * f for v, f in zip(sim.site.cell(j), scale, strict=True))
            for j in range(int(np.prod(sim.site.shape)))
        ]
        self._target_footprint = [self._footprint(cells) for cells in sim.site.target_cells]
        # Per component: (ready targets, obs indices, values) of its MY_TARGETS plane.
        self._my_targets: dict[int, tuple[list[int], np.ndarray, np.ndarray]] = {}
        self._assembly_steps = sim.scenario.assembly_steps
        self._move_limit = sim.site.move_limit
        self._limit = max(self._move_limit, 1)
        self._beam = [float(kind_spec(k).beam_feature) for k in sim.site.kind]
        self._n_components = sim.site.n_components

    def __getstate__(self) -> dict:
        # A memoryview and two views into the template: rebuilt on unpickling (a copied
        # view would no longer share the template's memory).
        state = self.__dict__.copy()
        for name in ("_bits", "planes", "table"):
            state.pop(name, None)
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        if "template" in state:
            self._bind_views()

    def _bind_views(self) -> None:
        X, Y = self.plan
        self._bits = memoryview(self.bits.reshape(-1))
        self.planes = self.template[self.layout.shared].reshape(X * Y, self.spec.n)
        self.table = self.template[self.layout.components].reshape(
            self.sim.site.n_components, COMPONENT_FEATURES
        )

    def _footprint(self, cells: list[int]) -> list[tuple[int, float]]:
        """(plan index, top height / H) of each (x, y) column a set of cells covers."""
        top: dict[int, int] = {}
        for j in cells:
            p = self._xy[j]
            top[p] = max(top.get(p, 0), self._z[j])
        return [(p, z / self.height) for p, z in top.items()]

    # -- the shared part -------------------------------------------------------------------

    def reset(self, step_limit: int) -> None:
        sim = self.sim
        X, Y = self.plan
        H = self.height
        self.step_limit = step_limit
        self.bits = np.zeros((X * Y, H + 1), dtype=np.uint8)
        # The shared planes and the component table are views into the template, which
        # every crane's observation starts as a copy of.
        self.template = np.zeros(self.layout.size, dtype=np.float32)
        self._bind_views()
        self._dirty_columns: set[int] = set()
        obstacles = np.flatnonzero(sim.site.static == WALL).tolist()
        self._paint(obstacles, 0, 1 << OBSTACLE)
        self._painted: list[tuple[list[int], int]] = [([], 0)] * sim.site.n_components
        self._targets_free = [True] * sim.site.n_components
        for t in range(sim.site.n_components):
            self._paint([], 0, (1 << FREE_TARGET) | (1 << ANY_TARGET), sim.site.target_cells[t])
        self._ready: set[int] = set()
        self._closed_seen = None

    def _paint(
        self, cells: list[int], bits: int, new_bits: int, new_cells: list[int] | None = None
    ):
        """Clear ``bits`` on ``cells``, then set ``new_bits`` on ``new_cells`` (default: same)."""
        byte, bm, xy, dirty = self._byte, self._bits, self._xy, self._dirty_columns
        if bits:
            keep = ~bits & 0xFF
            for j in cells:
                i = byte[j]
                if i >= 0:
                    bm[i] &= keep
                    dirty.add(xy[j])
        for j in cells if new_cells is None else new_cells:
            i = byte[j]
            if i >= 0:
                bm[i] |= new_bits
                dirty.add(xy[j])

    def _component_bits(self, c: int, status: int, ready: bool) -> int:
        if status == _INITIAL:
            return (1 << INITIAL) | ((1 << READY) if ready else 0)
        if status == _IN_TRANSIT:
            over = (1 << OVER_LIMIT) if self.sim.state.moves[c] > self._move_limit else 0
            return (1 << IN_TRANSIT) | over
        return 1 << AT_TARGET

    def _clear_component(self, c: int) -> None:
        """Take a component's bits off the cells it was painted on."""
        self._paint(*self._painted[c], 0, [])
        self._painted[c] = ([], 0)

    def _paint_component(self, c: int, ready: bool) -> None:
        """Paint a cleared component where it is now, and its table row."""
        st = self.sim.state
        cells, status = st.cells[c], int(st.status[c])
        bits = self._component_bits(c, status, ready)
        if not st.delivered[c]:  # off site: nothing of it is known but that
            cells, bits = [], 0
        self._paint([], 0, bits, cells)
        self._painted[c] = (cells, bits)
        if not cells:
            self.table[c] = 0.0
            return
        # The component table row (the "held by this crane" column is per crane).
        self.table[c] = (
            status == _INITIAL, status == _IN_TRANSIT, status == _ARRIVED, status == _ASSEMBLED,
            ready,
            st.holder[c] != NOBODY,
            0.0,
            self._beam[c],
            *self._scaled[cells[0]],
            *self._scaled[cells[-1]],
        )

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
        filled, target_cells = sim.state.filled, sim.site.target_cells
        # Every old cell is cleared before any new one is painted: a component may move into
        # a cell another one left in the same step.
        for c in changed:
            self._clear_component(c)
        for c in changed:
            self._paint_component(c, c in ready_now)
            t = int(filled[c])  # a target is filled only when a component arrives at it
            if t >= 0 and self._targets_free[t]:
                self._paint(target_cells[t], 1 << FREE_TARGET, 0)
                self._targets_free[t] = False
        if self._dirty_columns:
            idx = np.fromiter(self._dirty_columns, dtype=np.intp, count=len(self._dirty_columns))
            has = (self.bits[idx][:, :, None] & self._masks) != 0
            self.planes[idx] = (has * self._values).max(axis=1)
            self._dirty_columns.clear()
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

    def _targets_plane(self, targets: list[int]) -> tuple[np.ndarray, np.ndarray]:
        """Observation indices and values of the MY_TARGETS plane for a set of targets."""
        top: dict[int, float] = {}
        for t in targets:
            for p, z in self._target_footprint[t]:
                top[p] = max(top.get(p, 0.0), z)
        idx = np.array([self._own_start + p * N_OWN + 1 for p in top], dtype=np.intp)
        return idx, np.array(list(top.values()), dtype=np.float32)

    def observe(self, crane: int) -> np.ndarray:
        """A fresh array (the caller may keep it) with this crane's observation."""
        obs = self.template.copy()
        self._write_own(crane, obs)
        return obs

    def observe_all(self) -> np.ndarray:
        """Every crane's observation as the rows of one fresh (cranes, size) array: the
        shared part is written into all rows by one broadcast copy of the template, then
        each row gets its crane's own entries; row i equals ``observe(i)``."""
        n = self.sim.n_cranes
        out = np.empty((n, self.layout.size), dtype=np.float32)
        out[:] = self.template
        for crane in range(n):
            self._write_own(crane, out[crane])
        return out

    def _write_own(self, crane: int, obs: np.ndarray) -> None:
        """Write this crane's own entries into ``obs`` (a copy of the template)."""
        sim = self.sim
        st = sim.state
        comp = st.held[crane]
        if comp != NOBODY:
            own = self._own_start
            for p, z in self._footprint(st.cells[comp]):
                obs[own + p * N_OWN] = z
            ready = sim.ready_targets(comp)
            cached = self._my_targets.get(comp)
            if cached is None or cached[0] != ready:
                cached = (ready, *self._targets_plane(ready))
                self._my_targets[comp] = cached
            obs[cached[1]] = cached[2]
            obs[self._components_start + comp * COMPONENT_FEATURES + 6] = 1.0
            status = int(st.status[comp])
            moves = int(st.moves[comp])
            held = [1.0, status == _IN_TRANSIT, status == _ARRIVED,
                    min(moves / self._limit, 1.0), moves > self._move_limit]  # fmt: skip
        else:
            held = [0.0] * 5
        obs[self._crane] = (
            *held,
            st.assembling[crane] / self._assembly_steps,
            st.pass_over[crane],
            st.n_assembled / self._n_components,
            min(st.step_count / self.step_limit, 1.0),
        )
