"""The automatic mode's list pointer: which component an idle crane is given next.

``AutoPointer`` is the part of ``multicrane.sim.simulator.Simulator`` that runs only with
``auto=True`` (the paper's process): the cyclic pointer over the scenario's list order.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from multicrane.core.codes import Event, EventType, Status
from multicrane.sim.site import NOBODY

if TYPE_CHECKING:
    from multicrane.core.schema import Scenario
    from multicrane.sim.site import Site
    from multicrane.sim.state import SiteState

_INITIAL = int(Status.INITIAL)


class AutoPointer:
    """``_assign`` over ``self.state`` (set by the Simulator that inherits it)."""

    scenario: Scenario
    site: Site
    state: SiteState
    _status: memoryview
    _holder: memoryview
    _delivered: memoryview
    _has_ready: list[bool]
    _zones: list | None

    def _assign(self, crane: int, events: list[Event]) -> None:
        """Give an idle crane the next component of the list order (the paper's pointer).

        From the pointer on (cyclically): assembled entries are passed by, entries held by
        another crane are passed by, and beams with no supported free target are skipped;
        a pre-built entry reached for the first time becomes a pass-over step. The pointer
        then stands after the chosen entry. If a full cycle finds nothing, the crane idles.
        """
        st = self.state
        order = self.scenario.order
        n = len(order)
        for _ in range(n):
            pos = st.pointer
            comp = order[pos]
            st.pointer = (pos + 1) % n
            if st.prebuilt[comp]:
                if comp not in st.passed_over:
                    st.passed_over.add(comp)
                    st.pass_over[crane] = True
                    return
                continue
            if self._status[comp] != _INITIAL or self._holder[comp] != NOBODY:
                continue
            if not self._delivered[comp]:
                continue  # late: not on site yet
            if self.site.waits[comp] and not self._has_ready[comp]:
                continue
            if self._zones is not None and not self.in_reach(crane, comp):
                continue  # out of this crane's reach: skipped like a beam with no target
            st.held[crane] = comp
            self._holder[comp] = crane
            self._changed.add(comp)
            events.append(Event(st.step_count, crane, EventType.ASSIGNED, comp))
            return
