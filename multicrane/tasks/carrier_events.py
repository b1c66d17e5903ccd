"""The carrier on a site with events: it notices breakdowns, closures and deliveries, and replans.

``EventCarrier`` is ``multicrane.tasks.carrier.Carrier`` plus what a disturbed site needs; on an
episode without events (``sim.schedule`` is None) every method is the base one, so plans,
actions and makespans are exactly those of the static carrier.

Each decision round reads what is known *now* (``multicrane.sim.event_knowledge``: cranes down,
cells
closed, components not delivered; never the schedule's future) and compares it with the last
round:

- **Breakdown.** A crane that goes down keeps its component (the simulator's rule); that
  component is *frozen*: its plan is dropped, its cells are held for ever in the reservation
  table (the others plan around it), and its target stays kept for it (no other component is
  planned to it: releasing it could leave the frozen component with no target it can reach
  while it blocks the very component its last target waits for). The crane takes no new
  task while down. When it comes back, its component is planned again from
  where it is, to any free ready target (``Carrier._plan_transit``).
- **Closed zone.** Closed cells are obstacles from now on, until they open (their end is not
  known): held for ever by the owner ``CLOSED`` in the table, so a path, a claim's pick-up
  pose or a goal never touches them and a search with no way around fails ("wait and try
  again"). A component with a cell inside is frozen like one held by a broken crane.
- **Either** (a crane newly down, or cells newly closed): every plan of a component in transit
  is dropped and all are planned again in priority order (the carrier's full replan), since
  the plans around the frozen components and the closed cells are no longer valid.
- **Delivery.** A delivered component becomes claimable through the simulator and is planned
  like any other (a search reads the site's cells as they are now, so it sees the cells the
  component fills), and if a plan's path crosses the cells it appeared in, every plan in
  transit is replanned.

A component that a breakdown stopped on the pose of a target that was not ready then does not
arrive when the target becomes ready (arrival happens on a move): it is planned one step out
and back in.

Frozen components, and while some zone is closed components that found no path, do not stop
new tasks (on a static site one stranded component stops every new start until it has a
plan, so that no new path walls it in: disruptions are finite, so it is planned again once
they end).
"""

from __future__ import annotations

from multicrane.core.codes import Status
from multicrane.sim.event_knowledge import EventView, event_view, frozen_components
from multicrane.tasks.carrier import Carrier
from multicrane.tasks.reservation_arrays import ReservationArrays
from multicrane.tasks.reservations import INF, shape_of

CLOSED = -2  # the owner of a closed cell's reservations (components are 0..C-1)
_IN_TRANSIT = int(Status.IN_TRANSIT)


class EventCarrier(Carrier):
    """A ``Carrier`` that notices the site's events and replans (see the module doc).

    ``stats`` gains ``event_replans`` (full replans caused by a breakdown or a closure) on an
    episode with events.
    """

    def reset(self) -> None:
        super().reset()
        self._view: EventView | None = None
        self._frozen: set[int] = set()
        self._kept: dict[int, int] = {}  # frozen component -> the target its dropped plan had
        self._planning: int | None = None

    def taken_targets(self) -> set[int]:
        """The targets of every plan, and those kept for frozen components (but not the one
        kept for the component being planned now)."""
        taken = super().taken_targets()
        taken.update(t for c, t in self._kept.items() if c != self._planning)
        return taken

    def begin(self, T: int) -> None:
        if self._round == T:
            return
        view = event_view(self.sim)
        if view is None:
            self._view, self._frozen = None, set()
            super().begin(T)
            return
        if self._round is not None and self._round > T:
            self.reset()
        old = self._view
        self._view = view
        frozen = frozen_components(self.sim, view)
        self._frozen = frozen
        self.stats.setdefault("event_replans", 0)
        delivered = set(old.undelivered - view.undelivered) if old is not None else set()
        new_down = view.down - (old.down if old else frozenset())
        new_closed = set(view.closed) - set(old.closed if old else ())
        if new_down or new_closed or self._crossed(delivered, T):
            for comp in frozen:
                plan = self.plans.pop(comp, None)
                if plan is not None:
                    self._kept[comp] = plan.target
            self._force_replan = True
            self.stats["event_replans"] += 1
        status = self.sim.state.status
        self._kept = {c: t for c, t in self._kept.items() if status[c] == _IN_TRANSIT}
        super().begin(T)
        st = self.sim.state
        lenient = bool(view.closed)
        self._may_start = all(
            c in self.plans or c in frozen or lenient
            for c in range(self.sim.site.n_components)
            if st.status[c] == _IN_TRANSIT
        )

    def _crossed(self, comps: set[int], T: int) -> bool:
        """Some plan's path from ``T`` on enters the cells of one of ``comps`` (components
        just delivered into the yard: the plan was made while those cells were empty)."""
        if not comps:
            return False
        st = self.sim.state
        cells = {j for c in comps for j in st.cells[c]}
        for comp, plan in self.plans.items():
            rel = shape_of(self.sim, comp)
            for p in set(plan.positions[max(0, T - plan.t0) :]):
                if any(p + r in cells for r in rel):
                    return True
        return False

    def _fresh_table(self, T: int) -> ReservationArrays:
        res = super()._fresh_table(T)
        if self._view is not None and self._view.closed:
            res.hold(self._view.closed, T, INF, CLOSED)
        return res

    def _plan_parked(self, comps: list[int], T: int, res: ReservationArrays) -> list[int]:
        frozen = self._frozen
        return [c for c in comps if c in frozen or not self._plan_transit(c, T, res)]

    def _plan_transit(self, comp: int, T: int, res: ReservationArrays) -> bool:
        if self._view is None:
            return super()._plan_transit(comp, T, res)
        self._planning = comp
        try:
            planned = self._plan_transit_now(comp, T, res)
        finally:
            self._planning = None
        if planned:
            self._kept.pop(comp, None)
        return planned

    def _plan_transit_now(self, comp: int, T: int, res: ReservationArrays) -> bool:
        rel, start, crane, taken = self._in_transit(comp)
        for t in self.sim.ready_targets(comp):
            if t in taken or self.goals[rel, t] != start:
                continue
            # A breakdown stopped it on this target's pose before the target was ready: it
            # arrives only by moving in, so it steps out and back.
            path = self._out_and_back(comp, rel, start, T, res, crane, t)
            if path is not None:
                self._replace_transit_plan(comp, crane, t, T, path, rel, res)
                return True
        return super()._plan_transit(comp, T, res)

    def _out_and_back(
        self, comp: int, rel: tuple[int, ...], start: int, T: int, res: ReservationArrays,
        crane: int, target: int,
    ) -> list[int] | None:  # fmt: skip
        """``[start, q, start]``: one move out to a free neighbour pose and back, reserved
        by the table's rule (``multicrane.tasks.reservations``), or None."""
        sim = self.sim
        zone = crane if sim.site.reach is not None else -1
        stops = self._stops(comp, rel, target)
        here = [start + r for r in rel]
        if res.conflict(here, T + 1, INF, comp):
            return None
        for d in self.shapes.deltas.tolist():
            q = start + d
            if (self.shapes.fits(sim, rel, zone, q) and q not in stops
                    and not res.conflict([q + r for r in rel], T, T + 2, comp)):
                return [start, q, start]
        return None

    def reaches_pair(self, crane: int, comp: int, target: int) -> bool:
        return self.crane_up(crane) and super().reaches_pair(crane, comp, target)

    def cranes_down(self) -> frozenset[int] | tuple:
        return () if self._view is None else self._view.down


__all__ = ["CLOSED", "EventCarrier"]
