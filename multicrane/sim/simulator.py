"""The rules: reset, snapshot and step of one site (``Site``) and its episode state (``SiteState``).

It knows nothing of PettingZoo or Gymnasium. ``reset`` builds the state from a start (the
poses drawn by ``multicrane.sim.start``); ``step`` applies one action per crane, in the order
given, each seeing the site as the earlier ones left it, so two components can never end a
step in the same cell. The queries and action masks come from ``multicrane.sim.legality`` (the
same functions judge the actions). Every status change goes through the state machine's table
(``multicrane.sim.transitions``).

The static site is ``sim.site`` (``multicrane.sim.site``: padded grid, targets, supports) and the
episode's mutable state is ``sim.state`` (``multicrane.sim.state.SiteState``); the fields of both
are also readable as attributes of the simulator (``sim.status`` is ``sim.state.status``).
Readers (observation, reward, planners) read them and never write; ``sim.views``
(``StateViews``) holds memoryviews of the state's per-component arrays for hot paths.
``take_changed`` hands over the components whose cells or status changed since it was last
called.

**Site events** (``events=EventSpec``, see ``multicrane.sim.events`` and docs/uncertainty.md):
``reset`` draws the episode's ``EventSchedule`` from its generator (after the start) unless one
is given, and applies the events of time 0; each ``step`` applies those of the new time after
the actions, so the masks and observations handed out at time ``t`` already show them.
A late component appears in its yard pose once due and its cells are free and open; a crane
that is down may only wait (an assembly pauses, a held component stays held where it is);
closed cells refuse component cells. ``sim.schedule`` (None without events),
``sim.delivered(c)``, ``sim.crane_up(k)``, ``sim.closed`` ((P,) bool) tell the present;
``StepOutcome.site_events`` and ``sim.site_log`` (the episode's site events so far, in order)
tell what changed. Without a schedule nothing of this runs.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from multicrane.core.codes import (
    ASSEMBLE,
    CLAIM_BASE,
    N_MOVES,
    WAIT,
    Event,
    EventType,
    SiteEvent,
    Status,
)
from multicrane.core.schema import Scenario
from multicrane.sim.auto_pointer import AutoPointer
from multicrane.sim.events import EventSchedule, EventSpec, draw_schedule
from multicrane.sim.legality import Legality
from multicrane.sim.reach import check_crane_count
from multicrane.sim.site import FREE, NOBODY, WALL, Site
from multicrane.sim.site_events import SiteEvents
from multicrane.sim.start import Start, draw_start
from multicrane.sim.state import SiteState, StateViews
from multicrane.sim.transitions import event_of

__all__ = ["FREE", "NOBODY", "WALL", "Simulator", "StepOutcome"]

# Plain ints for the hot path: reading an IntEnum member costs a class __getattr__ in 3.11.
_INITIAL, _IN_TRANSIT, _ARRIVED, _ASSEMBLED = (int(s) for s in Status)
_VIEWS = ("views", "_occ", "_status", "_moves", "_holder", "_filled", "_filled_by", "_delivered")
_VIEWS += ("_target_at",)


@dataclass
class StepOutcome:
    """What one step did; the reward and the environments read it."""

    events: list[Event] = field(default_factory=list)
    assembled_by: list[int] = field(default_factory=list)  # crane of each assembly this step
    pass_over_by: list[int] = field(default_factory=list)  # crane of each pass-over step
    site_events: list[SiteEvent] = field(default_factory=list)  # the schedule's, at the new time


class Simulator(SiteEvents, Legality, AutoPointer):
    """One construction site with ``n_cranes`` cranes.

    ``auto=True`` is the paper's process: each idle crane is given the next component of the
    list order (a cyclic pointer; beams with no supported free target are skipped), its first
    move lifts it, and it is assembled on arrival. ``auto=False`` is the multi-agent process:
    cranes claim components (the claim lifts it), move them, and assemble them by action.

    With crane reach (``scenario.crane_specs``), ``n_cranes`` (default ``scenario.cranes``)
    must not exceed the cranes described (the first ``n_cranes`` are used) and those cranes
    must be able to carry every component (``multicrane.sim.reach``); else ValueError. Each crane
    then claims, is given and moves only what its zone allows (``multicrane.sim.legality``).
    """

    def __init__(
        self,
        scenario: Scenario,
        n_cranes: int | None = None,
        auto: bool = False,
        events: EventSpec | None = None,
        horizon: int | None = None,
    ):
        self.scenario = scenario
        self.events = events
        self.horizon = scenario.step_limit if horizon is None else int(horizon)
        self.n_cranes = scenario.cranes if n_cranes is None else int(n_cranes)
        if self.n_cranes < 1:
            raise ValueError(f"n_cranes must be at least 1, got {n_cranes!r}")
        self.auto = auto
        self.site = Site(scenario)
        self._zones = self.site.reach
        if self._zones is not None:
            check_crane_count(scenario, self.n_cranes)
            site = self.site
            self._zone_targets = [
                [
                    [t for t in site.compatible[c] if site.reaches(k, site.target_cells[t])]
                    for c in range(site.n_components)
                ]
                for k in range(self.n_cranes)
            ]
        self.start: Start | None = None
        self.state: SiteState | None = None
        self.schedule: EventSchedule | None = None
        self._closing = False
        self._closed = self.closed = np.zeros(self.site.size, dtype=bool)
        self._down = [False] * self.n_cranes
        self.site_log: list[SiteEvent] = []
        self.targets_version = 0

    def shared_with_copies(self) -> list:
        """What a copy of this episode (``copy.deepcopy``, as ``multicrane.envs.rollout_copy``
        makes one) may share with it instead of copying: the start, the fixed pick-up poses
        and the tables built from them and from the site, and the components' cell lists (a
        move replaces a component's list, never edits it)."""
        st = self.state
        fixed = [self.start, st.pickup, st.prebuilt, self._watch, self._target_users]
        return fixed + [self._supported_by, *st.cells]

    # -- pickling: memoryviews are rebuilt, not pickled -------------------------------------

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        for view in _VIEWS:
            state.pop(view, None)
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        if self.state is not None:  # reset has run
            self._bind()

    def _bind(self) -> None:
        """Hot-path caches: memoryviews of the state's and the site's arrays (an item of a
        memoryview is a plain int, read and written without making a numpy scalar)."""
        self.views = views = StateViews.of(self.state)
        self._occ = memoryview(self.state.occ)
        self._status, self._moves, self._holder = views.status, views.moves, views.holder
        self._filled, self._filled_by, self._delivered = views[3:]
        self._target_at = memoryview(self.site.target_at)

    # -- reset -----------------------------------------------------------------------------

    def reset(
        self,
        rng: np.random.Generator,
        start: Start | None = None,
        schedule: EventSchedule | None = None,
    ) -> None:
        """Start an episode from ``start`` (default: drawn from ``rng``); with ``events``,
        from ``schedule`` (default: drawn from ``rng`` after the start)."""
        self.rng = rng
        self.start = start if start is not None else draw_start(self.scenario, rng)
        if self.events is not None:  # one draw of rng, whether drawn here or given
            sub = np.random.default_rng(int(rng.integers(2**63)))
            if schedule is None:
                built = np.array([t >= 0 for t in self.start.prebuilt_target], dtype=bool)
                schedule = draw_schedule(
                    self.events, self.site, built, self.n_cranes, self.horizon, sub
                )
        self.schedule = schedule
        arrival = None if schedule is None else schedule.arrival
        self.state = SiteState.at_start(self.site, self.start, self.n_cranes, arrival)
        n = self.site.n_components
        self._bind()
        self._watch_pickups()
        self._claimable: set[int] = set()
        self._claimable_list: list[int] = []
        self._recheck: set[int] = set()
        self._changed: set[int] = set(range(n))  # components whose cells or status changed
        self.site_log = []
        self._time_events(0, [])
        self._refresh_targets()
        if self.auto:
            events: list[Event] = []
            for crane in range(self.n_cranes):
                if not self._down[crane]:
                    self._assign(crane, events)

    # -- snapshots for planners --------------------------------------------------------------

    def snapshot(self) -> SiteState:
        """The mutable state, copied: ``restore`` returns to it (for search-based planners)."""
        return self.state.copy()

    def restore(self, snap: SiteState) -> None:
        self.state.assign(snap)  # in place: the memoryviews stay valid
        if self.state.pickup is not self._watched_pickup:
            self._watch_pickups()
        self._changed = set(range(self.site.n_components))
        if self.schedule is not None:
            self._time_events(self.state.step_count, None)
        self._refresh_targets()

    def take_changed(self) -> set[int]:
        """The components whose cells or status changed since the last call (then none)."""
        changed = self._changed
        self._changed = set()
        return changed

    # -- the step --------------------------------------------------------------------------

    def step(self, actions: list[int], order: list[int] | None = None) -> StepOutcome:
        """Apply one action per crane; ``order`` is the order in which the cranes act."""
        st = self.state
        st.step_count += 1
        out = StepOutcome()
        for crane in order if order is not None else range(self.n_cranes):
            self._act(crane, int(actions[crane]), out)
        if self.auto:
            for crane in order if order is not None else range(self.n_cranes):
                if st.held[crane] == NOBODY and not st.pass_over[crane] and not self._down[crane]:
                    self._assign(crane, out.events)
        if self.schedule is not None:
            self._apply_events(st.step_count, out.site_events)
        return out

    def _set_status(self, comp: int, new: int) -> EventType:
        """Change a component's status along the state machine; returns the event to emit."""
        event = event_of(self._status[comp], new)
        self._status[comp] = new
        return event

    def _act(self, crane: int, action: int, out: StepOutcome) -> None:
        st = self.state
        t = st.step_count
        if self._down[crane]:  # broken down: only wait; an assembly pauses, a load stays
            if action != WAIT:
                out.events.append(Event(t, crane, EventType.ILLEGAL, detail="crane down"))
            return
        if st.pass_over[crane]:  # the paper's pass-over: the action is ignored
            st.pass_over[crane] = False
            out.events.append(Event(t, crane, EventType.PASS_OVER))
            out.pass_over_by.append(crane)
            return
        if st.assembling[crane]:
            if action != WAIT:
                out.events.append(Event(t, crane, EventType.ILLEGAL, detail=f"action {action}"))
            self._continue_assembly(crane, out)
            return
        comp = st.held[crane]
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
            st.assembling[crane] = self.scenario.assembly_steps
            out.events.append(
                Event(t, crane, EventType.ASSEMBLY_STARTED, comp, self._filled[comp])
            )
            self._continue_assembly(crane, out)
        else:
            self._claim(crane, action - CLAIM_BASE, out)

    def _claim(self, crane: int, comp: int, out: StepOutcome) -> None:
        st = self.state
        t = st.step_count
        if self.auto or st.held[crane] != NOBODY or not 0 <= comp < self.site.n_components:
            out.events.append(Event(t, crane, EventType.ILLEGAL, detail=f"claim {comp}"))
            return
        if self._holder[comp] != NOBODY and self._status[comp] != _ASSEMBLED:
            # Another crane took it earlier in this step (or holds it already).
            out.events.append(Event(t, crane, EventType.CLAIM_CONFLICT, comp))
            return
        if (
            self._status[comp] != _INITIAL
            or (self.site.waits[comp] and not self._has_ready[comp])
            or not self._delivered[comp]
        ):
            out.events.append(Event(t, crane, EventType.ILLEGAL, comp, detail=f"claim {comp}"))
            return
        if self._zones is not None and not self.in_reach(crane, comp):
            out.events.append(Event(t, crane, EventType.ILLEGAL, comp, detail="reach"))
            return
        if not self._lift_ok(comp):
            out.events.append(Event(t, crane, EventType.LIFT_BLOCKED, comp))
            return
        out.events.append(Event(t, crane, EventType.CLAIMED, comp))
        st.held[crane] = comp
        self._lift(crane, comp, out)

    def _lift(self, crane: int, comp: int, out: StepOutcome) -> bool:
        """Initial -> in transit: the component jumps to its pick-up pose if that is free."""
        st = self.state
        if not self._lift_ok(comp):
            out.events.append(Event(st.step_count, crane, EventType.LIFT_BLOCKED, comp))
            return False
        self._place(comp, st.pickup[comp])
        event = self._set_status(comp, _IN_TRANSIT)
        self._holder[comp] = crane
        out.events.append(Event(st.step_count, crane, event, comp))
        self._check_arrival(crane, comp, out)
        return True

    def _move(self, crane: int, comp: int, move: int, out: StepOutcome) -> None:
        st = self.state
        if self._status[comp] != _IN_TRANSIT:
            return  # it arrived on being lifted
        if not self.move_ok(comp, move):
            out.events.append(
                Event(st.step_count, crane, EventType.BLOCKED, comp, detail=str(move))
            )
            return
        if self._zones is not None and not self.move_in_reach(crane, comp, move):
            out.events.append(Event(st.step_count, crane, EventType.BLOCKED, comp, detail="reach"))
            return
        d = self.site.move_delta[move]
        self._place(comp, [j + d for j in st.cells[comp]])
        self._moves[comp] += 1
        self._check_arrival(crane, comp, out)

    def _place(self, comp: int, cells: list[int]) -> None:
        occ, watch, recheck = self._occ, self._watch, self._recheck
        st_cells = self.state.cells
        for j in st_cells[comp]:
            occ[j] = FREE
            if j in watch:
                recheck.update(watch[j])
        for j in cells:
            occ[j] = comp + 1
            if j in watch:
                recheck.update(watch[j])
        st_cells[comp] = cells
        self._changed.add(comp)
        recheck.add(comp)

    def _check_arrival(self, crane: int, comp: int, out: StepOutcome) -> None:
        site, st = self.site, self.state
        cells = st.cells[comp]
        t = self._target_at[cells[0]]
        if t == NOBODY or t not in site.compatible[comp]:
            return
        target = site.target_cellset[t]
        if len(target) != len(cells) or not target.issuperset(cells) or not self.target_ready[t]:
            return
        event = self._set_status(comp, _ARRIVED)
        self._filled[comp] = t
        self._filled_by[t] = comp
        self._update_targets([t])  # now filled; the targets it carries wait for assembly
        out.events.append(Event(st.step_count, crane, event, comp, t))
        if self.auto:
            self._assemble(crane, comp, out)

    def _continue_assembly(self, crane: int, out: StepOutcome) -> None:
        st = self.state
        st.assembling[crane] -= 1
        if st.assembling[crane] == 0:
            self._assemble(crane, st.held[crane], out)

    def _assemble(self, crane: int, comp: int, out: StepOutcome) -> None:
        st = self.state
        event = self._set_status(comp, _ASSEMBLED)
        self._holder[comp] = NOBODY
        st.held[crane] = NOBODY
        st.n_assembled += 1
        self._changed.add(comp)
        self._update_targets(self._supported_by[self._filled[comp]])
        out.events.append(Event(st.step_count, crane, event, comp, self._filled[comp]))
        out.assembled_by.append(crane)
