"""What a planner may know of the site's events now: cranes down, closed cells, undelivered parts.

Only the present is read (``sim.crane_up``, ``sim.closed``, ``sim.delivered``), never the drawn
schedule's future: a planner sees a breakdown or a closure when it starts and its end when it
ends. Without events (``sim.schedule`` is None, or a simulator without the events API)
``event_view`` returns None and planners behave exactly as on a static site.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from multicrane.core.codes import Status

_IN_TRANSIT = int(Status.IN_TRANSIT)


@dataclass(frozen=True)
class EventView:
    """The events visible at one moment."""

    down: frozenset[int]  # cranes unavailable now
    closed: tuple[int, ...]  # padded linear cells closed now, ascending
    undelivered: frozenset[int]  # components not yet on site

    @property
    def quiet(self) -> bool:
        """Nothing disturbs the site now (every crane up, no zone closed, all delivered)."""
        return not self.down and not self.closed and not self.undelivered


def event_view(sim) -> EventView | None:
    """The events of ``sim`` now, or None when its episode has no events."""
    if getattr(sim, "schedule", None) is None:
        return None
    n_comp = sim.site.n_components
    down = frozenset(k for k in range(sim.n_cranes) if not sim.crane_up(k))
    closed_mask = getattr(sim, "closed", None)
    closed = () if closed_mask is None else tuple(int(j) for j in np.flatnonzero(closed_mask))
    undelivered = frozenset(c for c in range(n_comp) if not sim.delivered(c))
    return EventView(down, closed, undelivered)


def frozen_components(sim, view: EventView | None) -> set[int]:
    """Components in transit that cannot move now: held by a crane that is down, or with a
    cell in a closed zone. They stay where they are (and block) until that ends."""
    if view is None or (not view.down and not view.closed):
        return set()
    st = sim.state
    closed = set(view.closed)
    out = set()
    for comp in range(sim.site.n_components):
        if st.status[comp] != _IN_TRANSIT:
            continue
        if int(st.holder[comp]) in view.down or closed.intersection(st.cells[comp]):
            out.add(comp)
    return out


__all__ = ["EventView", "event_view", "frozen_components"]
