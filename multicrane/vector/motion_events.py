"""Site events in kernels: a copy's drawn schedule applied as its time passes, and observed.

The kernels' half of ``multicrane.sim.site_events.SiteEvents`` for copy ``b``: the schedule
(``st.arrival``, ``st.outages``, ``st.closures``, written at reset by
``multicrane.vector.event_schedules``) turned into the present the rules read (``st.delivered``,
``st.down``, ``st.closed`` while ``st.closing``). ``start_events`` sets time 0 (at reset),
``apply_events`` the changes as a step makes the time ``t`` (after the actions), with the same
site events counted per ``SiteEventType`` (``buf.site_counts``). Breakdowns and closures only
change at an interval's start or end, so a step looks at the tables only when its time is the
copy's ``next_change``; deliveries due and still waiting are tried every step.
``write_events_block`` writes the observation's events block (``multicrane.envs.observation``).
"""

from __future__ import annotations

from multicrane.core.codes import SiteEventType
from multicrane.vector import paper_rules
from multicrane.vector.compiled import inlined
from multicrane.vector.motion_rules import mark_component, open_cells, refresh_ready

_DELIVERED = int(SiteEventType.DELIVERED)
_CRANE_DOWN = int(SiteEventType.CRANE_DOWN)
_CRANE_UP = int(SiteEventType.CRANE_UP)
_ZONE_CLOSED = int(SiteEventType.ZONE_CLOSED)
_ZONE_OPENED = int(SiteEventType.ZONE_OPENED)
_NEVER = 2**62  # a time no episode reaches
_START, _END = 6, 7  # the columns of a closure row holding its interval


@inlined
def _down_at(st, b, crane, t):
    """``EventSchedule.down_at`` for one crane."""
    for i in range(st.n_outages[b]):
        if st.outages[b, i, 0] == crane and st.outages[b, i, 1] <= t < st.outages[b, i, 2]:
            return True
    return False


@inlined
def _next_change(st, b, t):
    """The first time after ``t`` an outage or a closure starts or ends."""
    after = _NEVER
    for i in range(st.n_outages[b]):
        for u in (1, 2):
            if t < st.outages[b, i, u] < after:
                after = st.outages[b, i, u]
    for i in range(st.n_closures[b]):
        for u in (_START, _END):
            if t < st.closures[b, i, u] < after:
                after = st.closures[b, i, u]
    st.next_change[b] = after


@inlined
def _close_cells(site, st, buf, b, t):
    """``EventSchedule.closed_cells``: the cells of the closures in force at ``t``."""
    closed = st.closed
    for j in range(closed.shape[1]):
        closed[b, j] = False
    closing = False
    for i in range(st.n_closures[b]):
        box = st.closures[b, i]
        if not box[_START] <= t < box[_END]:
            continue
        closing = True
        for x in range(box[0], box[3] + 1):
            for y in range(box[1], box[4] + 1):
                base = site.column_base[x * site.plan_y + y]
                for z in range(box[2], box[5] + 1):
                    closed[b, base + z] = True
    st.closing[b] = closing
    buf.closed_changed[0] = True


@inlined
def _deliver(site, st, buf, b, t):
    """``SiteEvents._deliver``: late components due by ``t`` appear where their cells are
    free and open (the others wait for a later step)."""
    if st.n_pending[b] == 0:
        return
    for c in range(len(site.length)):
        if st.delivered[b, c] or st.arrival[b, c] > t:
            continue
        if not paper_rules.fits(st, b, c, st.cells, c):
            continue
        if st.closing[b] and not open_cells(st, b, st.cells[b, c]):
            continue
        for i in range(site.length[c]):
            st.occ[b, st.cells[b, c, i]] = c + 1
        st.delivered[b, c] = True
        st.n_pending[b] -= 1
        mark_component(site, st, buf, b, c)
        buf.site_counts[b, _DELIVERED] += 1


@inlined
def start_events(site, st, buf, b, count):
    """Time 0 of the schedule just written (``SiteState.at_start`` with arrivals and
    ``SiteEvents._time_events``): components due later off site, the cranes down and the
    cells closed at 0; their site events into ``buf.site_counts`` when ``count`` (else those
    of the step that ended the last episode stay)."""
    st.n_pending[b] = 0
    for c in range(len(site.length)):
        st.delivered[b, c] = st.arrival[b, c] <= 0
        if not st.delivered[b, c]:
            st.n_pending[b] += 1
            for i in range(site.length[c]):
                st.occ[b, st.cells[b, c, i]] = 0
    for k in range(site.n_cranes):
        st.down[b, k] = _down_at(st, b, k, 0)
    _close_cells(site, st, buf, b, 0)
    _next_change(st, b, 0)
    if not count:
        return
    counts = buf.site_counts
    for e in range(counts.shape[1]):
        counts[b, e] = 0
    for k in range(site.n_cranes):
        counts[b, _CRANE_DOWN] += st.down[b, k]
    for i in range(st.n_closures[b]):
        counts[b, _ZONE_CLOSED] += st.closures[b, i, _START] <= 0 < st.closures[b, i, _END]


@inlined
def apply_events(site, st, buf, b):
    """``SiteEvents._apply_events`` as copy ``b``'s time reaches its step count: cranes that
    break down or come back, closures that start or end (readiness refreshed then), and
    deliveries; the step's site events into ``buf.site_counts``."""
    counts = buf.site_counts
    for e in range(counts.shape[1]):
        counts[b, e] = 0
    t = st.step_count[b]
    if t == st.next_change[b]:
        for k in range(site.n_cranes):
            down = _down_at(st, b, k, t)
            if down != st.down[b, k]:
                counts[b, _CRANE_DOWN if down else _CRANE_UP] += 1
                st.down[b, k] = down
        changed = False
        for i in range(st.n_closures[b]):
            if st.closures[b, i, _START] == t:
                counts[b, _ZONE_CLOSED] += 1
                changed = True
            elif st.closures[b, i, _END] == t:
                counts[b, _ZONE_OPENED] += 1
                changed = True
        if changed:
            _close_cells(site, st, buf, b, t)
            refresh_ready(site, st, buf, b)  # readiness and claimability follow closed cells
        _next_change(st, b, t)
    _deliver(site, st, buf, b, t)


@inlined
def write_events_block(site, st, buf, b, full):
    """The observation's events block in every crane's row: delivered flags, available
    cranes and, when the closures changed (or ``full``), the closed plan (the height of the
    highest closed cell of each column, divided by H)."""
    obs = buf.obs
    C, N = len(site.length), site.n_cranes
    o = site.events_start
    for k in range(N):
        for c in range(C):
            obs[b, k, o + c] = st.delivered[b, c]
        for u in range(N):
            obs[b, k, o + C + u] = not st.down[b, u]
    if not (full or buf.closed_changed[0]):
        return
    buf.closed_changed[0] = False
    o += C + N
    for p in range(len(site.column_base)):
        top = 0
        if st.closing[b]:
            base = site.column_base[p]
            for z in range(1, site.height + 1):
                if st.closed[b, base + z]:
                    top = z
        for k in range(N):
            obs[b, k, o + p] = site.plane_z[top]
