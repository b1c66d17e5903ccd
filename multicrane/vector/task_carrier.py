"""The carrier's round for one copy, compiled: checks, replans, repairs, new tasks, actions.

Each function is the method of ``multicrane.tasks.carrier.Carrier`` (and of its planning
half, ``multicrane.tasks.carrier_planning``) it is named after, without site events, on the
plans of ``multicrane.vector.task_plans``: ``begin`` (drop finished plans, replan after a
divergence, plan parked components), ``try_start`` (a new task's search and claim),
``cancel``, ``repair`` (older plans crossing a new goal's stop poses), ``planned`` (each
crane's motion action) and ``time_left``.
"""

from __future__ import annotations

from multicrane.core.codes import ASSEMBLE, CLAIM_BASE, WAIT
from multicrane.tasks.search_kernels import conflict_kernel
from multicrane.vector.compiled import kernel
from multicrane.vector.task_plans import (
    CLAIMS,
    IN_TRANSIT,
    INITIAL,
    REPAIRS,
    REPLANS,
    arrival,
    in_order,
    move_at,
    position_at,
    put_plan,
    reaches,
    search,
    slot_of,
    stop_flags,
    table,
)

ARRIVED = 2


@kernel
def reset_carrier(tt, b):
    """``Carrier.reset``: no plans (the counters stay)."""
    for s in range(tt.slot_comp.shape[1]):
        tt.slot_comp[b, s] = -1
    for c in range(tt.seq.shape[1]):
        tt.seq[b, c] = 0
    for k in range(tt.claims.shape[1]):
        tt.claims[b, k] = -1
    tt.n_inserted[b] = 0
    tt.n_seq[b] = 0
    tt.round_t[b] = -1
    tt.may_start[b] = True
    tt.round_searches[b] = 0


@kernel
def _sync(ms, st, tt, b, T):
    """Drop finished plans; True when some component is not where its plan says."""
    diverged = False
    for s in range(tt.slot_comp.shape[1]):
        comp = tt.slot_comp[b, s]
        if comp < 0:
            continue
        status = st.status[b, comp]
        if status == INITIAL:
            if tt.slot_claim[b, s] and tt.slot_t0[b, s] > T:
                continue  # claimed in the coming step
            diverged = True
            tt.slot_comp[b, s] = -1
        elif status == IN_TRANSIT:
            if (tt.slot_t0[b, s] > T or st.cells[b, comp, 0] != position_at(tt, b, s, T)
                    or arrival(tt, b, s) <= T):  # fmt: skip
                diverged = True
                tt.slot_comp[b, s] = -1
        else:
            last = tt.slot_pos[b, s, tt.slot_len[b, s] - 1]
            at_goal = st.cells[b, comp, 0] == last and arrival(tt, b, s) <= T
            if st.filled[b, comp] != tt.slot_target[b, s] or not at_goal:
                diverged = True
            tt.slot_comp[b, s] = -1
    return diverged


@kernel
def _plan_transit(ms, st, ts, tt, sc, ss, b, comp, T):
    """Plan a component in transit from where it is to the nearest free ready targets
    (three at most, nearest first); True when a search found a path (then planned)."""
    start = st.cells[b, comp, 0]
    crane = st.holder[b, comp]
    shape = ts.shape_of[comp]
    S = tt.slot_comp.shape[1]
    keys = sc.options  # (distance, target, goal)
    n = 0
    for t in ms.compatible[comp]:
        if t < 0:
            break
        if not st.target_ready[b, t]:
            continue
        taken = False
        for s in range(S):
            if tt.slot_comp[b, s] >= 0 and tt.slot_target[b, s] == t:
                taken = True
        if taken or not reaches(ms, crane, ms.target_cells[t], ms.length[t]):
            continue
        goal = ts.goal[shape, t]
        if goal < 0:
            continue
        d = 0
        for i in range(3):
            d += abs(ts.coords[3 * start + i] - ts.coords[3 * goal + i])
        i = n  # insertion sort on (distance, target, goal)
        while i > 0 and (keys[i - 1, 0], keys[i - 1, 1]) > (d, t):
            for j in range(3):
                keys[i, j] = keys[i - 1, j]
            i -= 1
        keys[i, 0], keys[i, 1], keys[i, 2] = d, t, goal
        n += 1
    for i in range(min(n, 3)):
        t, goal = keys[i, 1], keys[i, 2]
        stop_flags(ms, st, ts, tt, sc, b, comp, t)
        length = search(ms, st, ts, tt, sc, ss, b, comp, start, T, goal, crane, False, T)
        if length:
            put_plan(tt, b, comp, crane, t, T, ss.path, length, False, True)
            return True
    return False


@kernel
def _plan_parked(ms, st, ts, tt, sc, ss, b, comps, n_comps, T):
    """Plan the first ``n_comps`` of ``comps`` (in transit without a plan), in order; those
    still parked go to the front of ``comps``: returns their count."""
    n = 0
    for i in range(n_comps):
        comp = comps[i]
        if not _plan_transit(ms, st, ts, tt, sc, ss, b, comp, T):
            comps[n] = comp
            n += 1
    return n


@kernel
def _replan_all(ms, st, ts, tt, sc, ss, b, T):
    """Drop every plan of a component in transit and plan them all again, oldest first."""
    C = len(ms.length)
    order = sc.order
    n = 0
    for c in range(C):
        if st.status[b, c] == IN_TRANSIT:
            s = slot_of(tt, b, c)
            if s >= 0:
                tt.slot_comp[b, s] = -1
            i = n  # stable insertion by creation number (none: 0)
            while i > 0 and tt.seq[b, order[i - 1]] > tt.seq[b, c]:
                order[i] = order[i - 1]
                i -= 1
            order[i] = c
            n += 1
    for _ in range(3):
        left = _plan_parked(ms, st, ts, tt, sc, ss, b, order, n, T)
        if left == 0 or left == n:
            break
        n = left


@kernel
def begin(ms, st, ts, tt, sc, ss, b, T):
    """Start the decision round at time ``T`` (once per ``T``)."""
    if tt.round_t[b] == T:
        return
    tt.round_t[b] = T
    N = ms.n_cranes
    for k in range(N):
        tt.claims[b, k] = -1
    tt.round_searches[b] = 0
    diverged = _sync(ms, st, tt, b, T)  # (a refused action forces a replan: events only)
    transit = sc.cranes
    n = 0
    for k in range(N):  # in transit = held by a crane; in index order
        c = st.held[b, k]
        if c >= 0 and st.status[b, c] == IN_TRANSIT:
            i = n
            while i > 0 and transit[i - 1] > c:
                transit[i] = transit[i - 1]
                i -= 1
            transit[i] = c
            n += 1
    unplanned = sc.parked
    m = 0
    for i in range(n):
        if slot_of(tt, b, transit[i]) < 0:
            unplanned[m] = transit[i]
            m += 1
    if diverged:
        tt.stats[b, REPLANS] += 1
        _replan_all(ms, st, ts, tt, sc, ss, b, T)
    elif m:
        _plan_parked(ms, st, ts, tt, sc, ss, b, unplanned, m, T)
    ok = True
    for i in range(n):
        if slot_of(tt, b, transit[i]) < 0:
            ok = False
    tt.may_start[b] = ok


@kernel
def try_start(ms, st, ts, tt, sc, ss, b, crane, comp, target):
    """Plan ``comp`` from its pick-up pose to ``target`` for ``crane``, claimed in the
    coming step; on success keep the plan and return True."""
    T = st.step_count[b]
    begin(ms, st, ts, tt, sc, ss, b, T)
    if not tt.may_start[b] or tt.claims[b, crane] >= 0 or slot_of(tt, b, comp) >= 0:
        return False
    L = ms.length[comp]
    pick = st.pickup[b, comp]
    if not reaches(ms, crane, pick, L) or not reaches(
            ms, crane, ms.target_cells[target], ms.length[target]):  # fmt: skip
        return False
    goal = ts.goal[ts.shape_of[comp], target]
    if goal < 0:
        return False
    n = table(ms, st, ts, tt, sc, b, T)
    cells = sc.cells[:L]
    for i in range(L):
        cells[i] = pick[i]
    if conflict_kernel(sc.rows, n, cells, T, T + 1, comp):
        return False  # the pick-up pose is not free in the claim step
    stop_flags(ms, st, ts, tt, sc, b, comp, target)
    start = cells[0]
    if sc.stop[start]:
        return False  # it would arrive at another target on being lifted
    tt.round_searches[b] += 1
    length = search(ms, st, ts, tt, sc, ss, b, comp, start, T + 1, goal, crane, True, T)
    if length == 0:
        return False
    put_plan(tt, b, comp, crane, target, T + 1, ss.path, length, True, True)
    tt.claims[b, crane] = comp
    tt.stats[b, CLAIMS] += 1
    return True


@kernel
def cancel(tt, b, crane):
    """Undo this round's ``try_start`` of ``crane`` (nothing was claimed yet)."""
    comp = tt.claims[b, crane]
    if comp < 0:
        return
    tt.claims[b, crane] = -1
    s = slot_of(tt, b, comp)
    if s >= 0:
        tt.slot_comp[b, s] = -1
    tt.stats[b, CLAIMS] -= 1


@kernel
def _repair(ms, st, ts, tt, sc, ss, b, T):
    """Replan the older plans (not claims) whose path from ``T`` on crosses a stop pose of
    this round's new goals; keep the old plan (put back last) if none is found."""
    n = in_order(tt, b, sc.slots)
    for i in range(n):
        s = sc.slots[i]
        comp = tt.slot_comp[b, s]
        if comp < 0 or tt.slot_claim[b, s] or st.status[b, comp] != IN_TRANSIT:
            continue
        new = False
        for k in range(ms.n_cranes):
            new |= tt.claims[b, k] == comp
        if new:
            continue
        stop_flags(ms, st, ts, tt, sc, b, comp, tt.slot_target[b, s])
        crosses = False
        for j in range(max(0, T - tt.slot_t0[b, s]), tt.slot_len[b, s] - 1):
            crosses |= sc.stop[tt.slot_pos[b, s, j]]
        if not crosses:
            continue
        tt.stats[b, REPAIRS] += 1
        tt.slot_comp[b, s] = -1  # the old plan stays in its slot, unlisted, until put back
        if not _plan_transit(ms, st, ts, tt, sc, ss, b, comp, T):
            _put_back(tt, b, s, comp)


@kernel
def _put_back(tt, b, s, comp):
    """List slot ``s`` (whose plan was taken out) again, last in the dict's order."""
    tt.slot_comp[b, s] = comp
    tt.n_inserted[b] += 1
    tt.slot_order[b, s] = tt.n_inserted[b]


@kernel
def planned(ms, st, ts, tt, sc, ss, b, T, joint):
    """``Carrier.actions``: older plans repaired if this round started tasks, then each
    crane's action for step ``T + 1`` into ``joint``."""
    begin(ms, st, ts, tt, sc, ss, b, T)
    for k in range(ms.n_cranes):
        if tt.claims[b, k] >= 0:
            _repair(ms, st, ts, tt, sc, ss, b, T)
            break
    for crane in range(ms.n_cranes):
        comp = st.held[b, crane]
        a = WAIT
        if st.assembling[b, crane]:
            a = WAIT
        elif comp < 0:
            if tt.claims[b, crane] >= 0:
                a = CLAIM_BASE + tt.claims[b, crane]
        elif st.status[b, comp] == ARRIVED:
            a = ASSEMBLE
        else:
            s = slot_of(tt, b, comp)
            d = 0 if s < 0 else move_at(tt, b, s, T)
            if d != 0:
                for m in range(len(ms.move_delta)):
                    if ms.move_delta[m] == d:
                        a = m
        joint[crane] = a


@kernel
def carrier_time_left(ms, st, tt, b, crane):
    """``Carrier.time_left``: the path left plus the assembly."""
    steps = ms.assembly_steps
    if st.assembling[b, crane]:
        return st.assembling[b, crane]
    comp = st.held[b, crane]
    if comp < 0:
        comp = tt.claims[b, crane]
        if comp < 0:
            return 0
    if st.status[b, comp] == ARRIVED:
        return steps
    s = slot_of(tt, b, comp)
    if s < 0:
        return steps + 1
    return max(arrival(tt, b, s) - st.step_count[b], 1) + steps


__all__ = ["begin", "cancel", "carrier_time_left", "planned", "reset_carrier", "try_start"]
