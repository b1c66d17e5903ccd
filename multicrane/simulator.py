"""The simulator core: occupancy, the component state machine, cranes and their actions.

It knows nothing of PettingZoo or Gymnasium. ``reset`` builds the state from a start (the
poses drawn by ``multicrane.start``); ``step`` applies one action per crane, in the order
given, each seeing the site as the earlier ones left it, so two components can never end a
step in the same cell. Legality lives here only: the action masks are computed by the same
functions that judge the actions.

Occupancy is one ``int16`` grid padded by a wall on every side (index ``x + 1, y + 1, z``;
layer ``z = 0`` is the ground and layer ``height + 1`` the sky, both walls). A cell holds
``FREE``, ``WALL`` (wall, ground or obstacle) or ``component index + 1``. The hot path reads and
writes it through a memoryview with linear indices; a move adds one constant to each of a
component's cell indices.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from multicrane import geometry
from multicrane.scenario import Scenario
from multicrane.start import Start, draw_start
from multicrane.types import (
    ASSEMBLE,
    CLAIM_BASE,
    MOVE_DELTAS,
    N_MOVES,
    WAIT,
    Event,
    EventType,
    Kind,
    Status,
)

FREE = 0
WALL = -1
NOBODY = -1
# Plain ints for the hot path: reading an IntEnum member costs a class __getattr__ in 3.11.
_INITIAL, _IN_TRANSIT, _ARRIVED, _ASSEMBLED = (int(s) for s in Status)
_BEAM = int(Kind.BEAM)


@dataclass
class StepOutcome:
    """What one step did; the reward and the environments read it."""

    events: list[Event] = field(default_factory=list)
    assembled_by: list[int] = field(default_factory=list)  # crane of each assembly this step
    pass_over_by: list[int] = field(default_factory=list)  # crane of each pass-over step


class Simulator:
    """One construction site with ``n_cranes`` cranes.

    ``auto=True`` is the paper's process: each idle crane is given the next component of the
    list order (a cyclic pointer; beams with no supported free target are skipped), its first
    move lifts it, and it is assembled on arrival. ``auto=False`` is the multi-agent process:
    cranes claim components (the claim lifts it), move them, and assemble them by action.
    """

    def __init__(self, scenario: Scenario, n_cranes: int | None = None, auto: bool = False):
        self.scenario = scenario
        self.n_cranes = scenario.cranes if n_cranes is None else int(n_cranes)
        if self.n_cranes < 1:
            raise ValueError(f"n_cranes must be at least 1, got {n_cranes!r}")
        self.auto = auto
        self.n_actions = CLAIM_BASE + scenario.n_components
        X, Y, H = scenario.size
        self.shape = (X + 2, Y + 2, H + 2)
        self._sx = (Y + 2) * (H + 2)
        self._sy = H + 2
        self.move_delta = [dx * self._sx + dy * self._sy + dz for dx, dy, dz in MOVE_DELTAS]
        comps = scenario.components
        self.n_components = len(comps)
        self.kind = [int(c.kind) for c in comps]
        self.length = [c.length for c in comps]
        self.move_limit = scenario.reward.move_limit
        # Targets share the component indices; cells as linear indices.
        self.target_cells = [self._lin_pose(c.target) for c in comps]
        self.target_cellset = [frozenset(t) for t in self.target_cells]
        self.target_supports = self._target_supports()
        self.compatible = [self._compatible_targets(i) for i in range(len(comps))]
        self.target_at = np.full(self.shape, NOBODY, dtype=np.int16).reshape(-1)
        for t, cells in enumerate(self.target_cells):
            self.target_at[cells] = t
        self._target_at = memoryview(self.target_at)
        self._static = self._static_grid()
        self.start: Start | None = None

    # -- pickling: memoryviews are rebuilt, not pickled -------------------------------------

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        for view in ("_occ", "_status", "_target_at"):
            state.pop(view, None)
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._target_at = memoryview(self.target_at)
        if "occ" in state:  # reset has run
            self._occ = memoryview(self.occ)
            self._status = memoryview(self.status)

    # -- coordinates ---------------------------------------------------------------------

    def lin(self, x: int, y: int, z: int) -> int:
        """Linear index of site cell (x, y, z) in the padded grid."""
        return (x + 1) * self._sx + (y + 1) * self._sy + z

    def cell(self, index: int) -> tuple[int, int, int]:
        """Site cell (x, y, z) of a linear index."""
        px, rest = divmod(index, self._sx)
        py, z = divmod(rest, self._sy)
        return (px - 1, py - 1, z)

    def _lin_pose(self, pose: geometry.Pose) -> list[int]:
        return [self.lin(*c) for c in geometry.pose_cells(*pose)]

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
        target of the same kind, length and orientation. A lifted component keeps the
        orientation of its own target (there is no rotation move), so a target of another
        orientation could never be filled; leaving it out keeps masks and skips honest."""
        comps = self.scenario.components
        if not self.scenario.interchangeable_targets:
            return [comp]
        own = comps[comp]
        shape = (own.kind, own.length, geometry.axis_of(*own.target))
        return [
            j
            for j, other in enumerate(comps)
            if (other.kind, other.length, geometry.axis_of(*other.target)) == shape
        ]

    def _target_supports(self) -> list[list[int]]:
        """Targets that must hold assembled components before this target can be filled.

        Beams name theirs; a column target standing on another column target needs that one.
        """
        comps = self.scenario.components
        supports = []
        for c in comps:
            if c.kind is Kind.BEAM:
                supports.append(list(c.supports))
                continue
            bottom = min(geometry.pose_cells(*c.target), key=lambda cell: cell[2])
            below = self.lin(bottom[0], bottom[1], bottom[2] - 1)
            supports.append([t for t, cells in enumerate(self.target_cells) if below in cells])
        return supports

    # -- reset -----------------------------------------------------------------------------

    def reset(self, rng: np.random.Generator, start: Start | None = None) -> None:
        """Start an episode from ``start`` (default: drawn from ``rng``)."""
        self.rng = rng
        self.start = start if start is not None else draw_start(self.scenario, rng)
        n = self.n_components
        self.occ = self._static.copy().reshape(-1)
        self._occ = memoryview(self.occ)
        self.status = np.full(n, Status.INITIAL, dtype=np.int8)
        self.moves = np.zeros(n, dtype=np.int32)
        self.holder = np.full(n, NOBODY, dtype=np.int16)  # crane holding each component
        self.filled = np.full(n, NOBODY, dtype=np.int16)  # target each component fills
        self.filled_by = np.full(n, NOBODY, dtype=np.int16)  # component filling each target
        self.prebuilt = np.zeros(n, dtype=bool)
        self.cells: list[list[int]] = [[] for _ in range(n)]
        self.pickup: list[list[int]] = [[] for _ in range(n)]
        for i, c in enumerate(self.scenario.components):
            t = self.start.prebuilt_target[i]
            if t >= 0:
                self.cells[i] = list(self.target_cells[t])
                self.status[i] = Status.ASSEMBLED
                self.prebuilt[i] = True
                self.filled[i] = t
                self.filled_by[t] = i
            else:
                pose = self.start.initial[i]
                assert pose is not None
                self.cells[i] = self._lin_pose(pose)
                lifted = geometry.pickup_pose(c, self.scenario.beam_lift_z, pose)
                self.pickup[i] = self._lin_pose(lifted)
            for j in self.cells[i]:
                assert self._occ[j] == FREE, "the loader and the start draw guarantee free cells"
                self._occ[j] = i + 1
        self._status = memoryview(self.status)
        # Claimability bookkeeping: which components' pick-up poses cover each cell.
        self._watch: dict[int, list[int]] = {}
        for i, cells in enumerate(self.pickup):
            for j in cells:
                self._watch.setdefault(j, []).append(i)
        self._claimable: set[int] = set()
        self._claimable_list: list[int] = []
        self._recheck: set[int] = set()
        self._refresh_targets()
        self.n_placed = int(self.prebuilt.sum())  # assembled components, pre-built included
        self.n_prebuilt = self.n_placed
        self.step_count = 0
        # Cranes.
        self.held = [NOBODY] * self.n_cranes
        self.assembling = [0] * self.n_cranes  # steps of assembly left
        self.pass_over = [False] * self.n_cranes  # auto mode: next step is a pass-over
        self.pointer = 0
        self.passed_over: set[int] = set()
        self.dirty: set[int] = set(range(n))  # components whose cells or status changed
        if self.auto:
            events: list[Event] = []
            for crane in range(self.n_cranes):
                self._assign(crane, events)

    # -- snapshots for planners --------------------------------------------------------------

    def snapshot(self) -> tuple:
        """The mutable state, copied: ``restore`` returns to it (for search-based planners)."""
        return (
            self.occ.copy(),
            self.status.copy(),
            self.moves.copy(),
            self.holder.copy(),
            self.filled.copy(),
            self.filled_by.copy(),
            list(self.cells),  # _place replaces a component's list, never mutates it
            list(self.held),
            list(self.assembling),
            list(self.pass_over),
            self.pointer,
            set(self.passed_over),
            self.n_placed,
            self.step_count,
        )

    def restore(self, snap: tuple) -> None:
        (occ, status, moves, holder, filled, filled_by, cells, held, assembling, pass_over,
         self.pointer, passed_over, self.n_placed, self.step_count) = snap  # fmt: skip
        for mine, saved in (
            (self.occ, occ),
            (self.status, status),
            (self.moves, moves),
            (self.holder, holder),
            (self.filled, filled),
            (self.filled_by, filled_by),
        ):
            np.copyto(mine, saved)  # in place: the memoryviews stay valid
        self.cells = list(cells)
        self.held = list(held)
        self.assembling = list(assembling)
        self.pass_over = list(pass_over)
        self.passed_over = set(passed_over)
        self.dirty = set(range(self.n_components))
        self._refresh_targets()

    # -- queries shared by the rules and the masks -------------------------------------------

    @property
    def done(self) -> bool:
        return self.n_placed == self.n_components

    @property
    def k(self) -> int:
        """Components assembled during this episode (pre-built ones excluded)."""
        return self.n_placed - self.n_prebuilt

    def fits(self, comp: int, cells: list[int]) -> bool:
        """True when every cell is free or already held by ``comp``."""
        occ = self._occ
        own = comp + 1
        for j in cells:
            v = occ[j]
            if v != FREE and v != own:
                return False
        return True

    def _target_ready_now(self, t: int) -> bool:
        """A target can be filled: it is free and all its supports are assembled."""
        if self.filled_by[t] != NOBODY:
            return False
        for s in self.target_supports[t]:
            f = self.filled_by[s]
            if f == NOBODY or self._status[f] != _ASSEMBLED:
                return False
        return True

    def _refresh_targets(self) -> None:
        """Recompute target readiness; it changes only when a component arrives or is
        assembled, so the step calls this then and every query reads the cache."""
        self.target_ready = [self._target_ready_now(t) for t in range(self.n_components)]
        ready = self.target_ready
        self._has_ready = [
            any(ready[t] for t in self.compatible[c]) for c in range(self.n_components)
        ]
        self._recheck.update(range(self.n_components))

    def ready_targets(self, comp: int) -> list[int]:
        """Targets this component could arrive at now."""
        ready = self.target_ready
        return [t for t in self.compatible[comp] if ready[t]]

    def can_lift(self, comp: int) -> bool:
        return self._status[comp] == _INITIAL and self.fits(comp, self.pickup[comp])

    def claimable(self, comp: int) -> bool:
        """An initial, unclaimed component whose pick-up pose is free and that has somewhere
        to go (a beam with no supported free target waits, as in the paper)."""
        return (
            self._status[comp] == _INITIAL
            and self.holder[comp] == NOBODY
            and self.fits(comp, self.pickup[comp])
            and (self.kind[comp] != _BEAM or self._has_ready[comp])
        )

    def claimable_components(self) -> list[int]:
        """Every component a crane may claim now, in index order.

        Kept incrementally: ``_place`` marks the components whose pick-up pose it touched,
        and a change of target readiness marks them all; only those are judged again.
        """
        if self.auto:
            return []
        recheck = self._recheck
        if recheck:
            claimable = self._claimable
            for c in recheck:
                if self.claimable(c):
                    claimable.add(c)
                else:
                    claimable.discard(c)
            recheck.clear()
            self._claimable_list = sorted(self._claimable)
        return self._claimable_list

    def move_ok(self, comp: int, move: int) -> bool:
        """The move is not blocked. An initial component is judged from its pick-up pose."""
        cells = self.cells[comp] if self._status[comp] == _IN_TRANSIT else self.pickup[comp]
        d = self.move_delta[move]
        occ = self._occ
        own = comp + 1
        for j in cells:
            v = occ[j + d]
            if v != FREE and v != own:
                return False
        return True

    def action_mask(self, crane: int) -> np.ndarray:
        """Legal actions of one crane (int8, length ``n_actions``); wait is always legal."""
        return self.action_masks()[crane]

    def action_masks(self) -> np.ndarray:
        """Legal actions of every crane, one int8 row each (a fresh array)."""
        masks = np.zeros((self.n_cranes, self.n_actions), dtype=np.int8)
        masks[:, WAIT] = 1
        claims = None
        for crane in range(self.n_cranes):
            if self.assembling[crane] or self.pass_over[crane]:
                continue
            row = masks[crane]
            comp = self.held[crane]
            if comp == NOBODY:
                if not self.auto:
                    if claims is None:
                        claims = [CLAIM_BASE + c for c in self.claimable_components()]
                    row[claims] = 1
                continue
            status = self._status[comp]
            if status == _ARRIVED:
                row[ASSEMBLE] = 1
            elif status == _IN_TRANSIT or (status == _INITIAL and self.can_lift(comp)):
                row[:N_MOVES] = self.moves_ok(comp)
        return masks

    def moves_ok(self, comp: int) -> list[bool]:
        """``move_ok`` for the six moves at once."""
        cells = self.cells[comp] if self._status[comp] == _IN_TRANSIT else self.pickup[comp]
        occ = self._occ
        own = comp + 1
        out = []
        for d in self.move_delta:
            for j in cells:
                v = occ[j + d]
                if v != FREE and v != own:
                    out.append(False)
                    break
            else:
                out.append(True)
        return out

    def over_limit(self) -> list[int]:
        """Cranes holding a component that has made more moves than the move limit."""
        return [
            crane
            for crane, comp in enumerate(self.held)
            if comp != NOBODY and self.moves[comp] > self.move_limit
        ]

    # -- the step --------------------------------------------------------------------------

    def step(self, actions: list[int], order: list[int] | None = None) -> StepOutcome:
        """Apply one action per crane; ``order`` is the order in which the cranes act."""
        self.step_count += 1
        out = StepOutcome()
        for crane in order if order is not None else range(self.n_cranes):
            self._act(crane, int(actions[crane]), out)
        if self.auto:
            for crane in order if order is not None else range(self.n_cranes):
                if self.held[crane] == NOBODY and not self.pass_over[crane]:
                    self._assign(crane, out.events)
        return out

    def _act(self, crane: int, action: int, out: StepOutcome) -> None:
        t = self.step_count
        if self.pass_over[crane]:  # the paper's pass-over: the action is ignored
            self.pass_over[crane] = False
            out.events.append(Event(t, crane, EventType.PASS_OVER))
            out.pass_over_by.append(crane)
            return
        if self.assembling[crane]:
            if action != WAIT:
                out.events.append(Event(t, crane, EventType.ILLEGAL, detail=f"action {action}"))
            self._continue_assembly(crane, out)
            return
        comp = self.held[crane]
        if action < N_MOVES:
            if comp == NOBODY or self._status[comp] == _ARRIVED:
                out.events.append(Event(t, crane, EventType.ILLEGAL, comp, detail=f"move {action}"))
                return
            if self._status[comp] == _INITIAL and not self._lift(crane, comp, out):
                return
            self._move(crane, comp, action, out)
        elif action == WAIT:
            return
        elif action == ASSEMBLE:
            if self.auto or comp == NOBODY or self._status[comp] != _ARRIVED:
                out.events.append(Event(t, crane, EventType.ILLEGAL, comp, detail="assemble"))
                return
            self.assembling[crane] = self.scenario.assembly_steps
            out.events.append(
                Event(t, crane, EventType.ASSEMBLY_STARTED, comp, int(self.filled[comp]))
            )
            self._continue_assembly(crane, out)
        else:
            self._claim(crane, action - CLAIM_BASE, out)

    def _claim(self, crane: int, comp: int, out: StepOutcome) -> None:
        t = self.step_count
        if self.auto or self.held[crane] != NOBODY or not 0 <= comp < self.n_components:
            out.events.append(Event(t, crane, EventType.ILLEGAL, detail=f"claim {comp}"))
            return
        if self.holder[comp] != NOBODY and self._status[comp] != _ASSEMBLED:
            # Another crane took it earlier in this step (or holds it already).
            out.events.append(Event(t, crane, EventType.CLAIM_CONFLICT, comp))
            return
        if self._status[comp] != _INITIAL or (
            self.kind[comp] == _BEAM and not self._has_ready[comp]
        ):
            out.events.append(Event(t, crane, EventType.ILLEGAL, comp, detail=f"claim {comp}"))
            return
        if not self.fits(comp, self.pickup[comp]):
            out.events.append(Event(t, crane, EventType.LIFT_BLOCKED, comp))
            return
        out.events.append(Event(t, crane, EventType.CLAIMED, comp))
        self.held[crane] = comp
        self._lift(crane, comp, out)

    def _lift(self, crane: int, comp: int, out: StepOutcome) -> bool:
        """Initial -> in transit: the component jumps to its pick-up pose if that is free."""
        if not self.fits(comp, self.pickup[comp]):
            out.events.append(Event(self.step_count, crane, EventType.LIFT_BLOCKED, comp))
            return False
        self._place(comp, self.pickup[comp])
        self._status[comp] = _IN_TRANSIT
        self.holder[comp] = crane
        out.events.append(Event(self.step_count, crane, EventType.LIFTED, comp))
        self._check_arrival(crane, comp, out)
        return True

    def _move(self, crane: int, comp: int, move: int, out: StepOutcome) -> None:
        if self._status[comp] != _IN_TRANSIT:
            return  # it arrived on being lifted
        if not self.move_ok(comp, move):
            out.events.append(
                Event(self.step_count, crane, EventType.BLOCKED, comp, detail=str(move))
            )
            return
        d = self.move_delta[move]
        self._place(comp, [j + d for j in self.cells[comp]])
        self.moves[comp] += 1
        self._check_arrival(crane, comp, out)

    def _place(self, comp: int, cells: list[int]) -> None:
        occ, watch, recheck = self._occ, self._watch, self._recheck
        for j in self.cells[comp]:
            occ[j] = FREE
            if j in watch:
                recheck.update(watch[j])
        for j in cells:
            occ[j] = comp + 1
            if j in watch:
                recheck.update(watch[j])
        self.cells[comp] = cells
        self.dirty.add(comp)
        recheck.add(comp)

    def _check_arrival(self, crane: int, comp: int, out: StepOutcome) -> None:
        cells = self.cells[comp]
        t = self._target_at[cells[0]]
        if t == NOBODY or t not in self.compatible[comp]:
            return
        target = self.target_cellset[t]
        if len(target) != len(cells) or not target.issuperset(cells) or not self.target_ready[t]:
            return
        self._status[comp] = _ARRIVED
        self.filled[comp] = t
        self.filled_by[t] = comp
        self._refresh_targets()
        out.events.append(Event(self.step_count, crane, EventType.ARRIVED, comp, t))
        if self.auto:
            self._assemble(crane, comp, out)

    def _continue_assembly(self, crane: int, out: StepOutcome) -> None:
        self.assembling[crane] -= 1
        if self.assembling[crane] == 0:
            self._assemble(crane, self.held[crane], out)

    def _assemble(self, crane: int, comp: int, out: StepOutcome) -> None:
        self._status[comp] = _ASSEMBLED
        self.holder[comp] = NOBODY
        self.held[crane] = NOBODY
        self.n_placed += 1
        self.dirty.add(comp)
        self._refresh_targets()
        out.events.append(
            Event(self.step_count, crane, EventType.ASSEMBLED, comp, int(self.filled[comp]))
        )
        out.assembled_by.append(crane)

    # -- automatic mode: the list pointer ----------------------------------------------------

    def _assign(self, crane: int, events: list[Event]) -> None:
        """Give an idle crane the next component of the list order (the paper's pointer).

        From the pointer on (cyclically): placed entries are passed by, entries held by
        another crane are passed by, and beams with no supported free target are skipped;
        a pre-built entry reached for the first time becomes a pass-over step. The pointer
        then stands after the chosen entry. If a full cycle finds nothing, the crane idles.
        """
        order = self.scenario.order
        n = len(order)
        for _ in range(n):
            pos = self.pointer
            comp = order[pos]
            self.pointer = (pos + 1) % n
            if self.prebuilt[comp]:
                if comp not in self.passed_over:
                    self.passed_over.add(comp)
                    self.pass_over[crane] = True
                    return
                continue
            if self._status[comp] != _INITIAL or self.holder[comp] != NOBODY:
                continue
            if self.kind[comp] == _BEAM and not self._has_ready[comp]:
                continue
            self.held[crane] = comp
            self.holder[comp] = crane
            self.dirty.add(comp)
            events.append(Event(self.step_count, crane, EventType.ASSIGNED, comp))
            return
