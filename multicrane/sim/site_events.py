"""The simulator's site events: the episode's schedule applied as time passes.

``SiteEvents`` is the half of ``multicrane.sim.simulator.Simulator`` that applies the schedule
drawn at reset (``multicrane.sim.events``): which cranes are down, which cells are closed, and
which late components appear in the yard, at each time ``t`` the state reaches (reset for
``t = 0``, the end of a step for later times). It writes only ``state.occ`` and
``state.delivered`` (a delivery) and its own caches; the legality queries read them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from multicrane.core.codes import SiteEvent, SiteEventType

if TYPE_CHECKING:
    from multicrane.sim.events import EventSchedule
    from multicrane.sim.site import Site
    from multicrane.sim.state import SiteState


class SiteEvents:
    """Applies ``self.schedule`` to ``self.state`` (set by the Simulator that inherits it)."""

    site: Site
    state: SiteState
    schedule: EventSchedule | None
    n_cranes: int
    site_log: list[SiteEvent]

    def _time_events(self, t: int, events: list[SiteEvent] | None) -> None:
        """Set the crane and closure state of time ``t`` from the schedule (reset, restore);
        at reset (``events`` a list) also deliver what is due and log the events of ``t``."""
        sched = self.schedule
        self._down = [False] * self.n_cranes
        self._closed = self.closed = np.zeros(self.site.size, dtype=bool)
        self._closing = False
        self._pending: list[int] = []
        if sched is None:
            return
        self._pending = sorted(
            (c for c in range(self.site.n_components) if not self.state.delivered[c]),
            key=lambda c: (int(sched.arrival[c]), c),
        )
        self._down = sched.down_at(self.n_cranes, t)
        self._closed = self.closed = sched.closed_cells(self.site.size, t)
        self._closing = bool(self._closed.any())
        if events is None:
            return
        for k, down in enumerate(self._down):
            if down:
                events.append(SiteEvent(t, SiteEventType.CRANE_DOWN, crane=k))
        for i in sched.closures_at(t):
            events.append(SiteEvent(t, SiteEventType.ZONE_CLOSED, closure=i))
        self._deliver(t, events)
        self.site_log.extend(events)

    def _apply_events(self, t: int, events: list[SiteEvent]) -> None:
        """The schedule's changes as time reaches ``t`` (after the actions of the step)."""
        sched = self.schedule
        down = sched.down_at(self.n_cranes, t)
        for k in range(self.n_cranes):
            if down[k] != self._down[k]:
                kind = SiteEventType.CRANE_DOWN if down[k] else SiteEventType.CRANE_UP
                events.append(SiteEvent(t, kind, crane=k))
        self._down = down
        changed = False
        for i, c in enumerate(sched.closures):
            if c.start == t or c.end == t:
                kind = SiteEventType.ZONE_CLOSED if c.start == t else SiteEventType.ZONE_OPENED
                events.append(SiteEvent(t, kind, closure=i))
                changed = True
        if changed:
            self._closed = self.closed = sched.closed_cells(self.site.size, t)
            self._closing = bool(self._closed.any())
            self._refresh_targets()  # readiness and claimability depend on closed cells
        self._deliver(t, events)
        self.site_log.extend(events)

    def _deliver(self, t: int, events: list[SiteEvent]) -> None:
        """Late components due by ``t`` appear in the yard where their cells are free and
        open (one whose cells are taken or closed waits, and is tried again each step)."""
        if not self._pending:
            return
        arrival, st = self.schedule.arrival, self.state
        left = []
        for c in self._pending:
            cells = st.cells[c]
            if arrival[c] > t or not self.fits(c, cells) or not self.open_cells(cells):
                left.append(c)
                continue
            occ, watch, recheck = self._occ, self._watch, self._recheck
            for j in cells:
                occ[j] = c + 1
                if j in watch:
                    recheck.update(watch[j])
            st.delivered[c] = True
            self._changed.add(c)
            recheck.add(c)
            events.append(SiteEvent(t, SiteEventType.DELIVERED, component=c))
        self._pending = left

