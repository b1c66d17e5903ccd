"""The carrier's plans and searches for one copy, compiled: plan slots, reservations, stops, A*.

A copy's plans live in ``TaskState``'s slots (``multicrane.vector.task_state``), positions
included; ``in_order`` lists the slots as the carrier's ``plans`` dict orders them (insertion
order: a plan put back after a failed repair goes last, as a dict key deleted and set again
does). The reservation table is built from the plans when a search or a claim asks
(``table``): every component in transit holds its plan's path from the round's time on (or,
with none, its cells for ever), and so does every planned claim, which is what
``ReservationArrays`` holds at every point of a round in ``multicrane.tasks.carrier`` (row order
never matters to its readers). ``search`` is ``CarrierPlanning._search``: the same compiled A*
(``multicrane.tasks.search_kernels``) on the same inputs, so the same path; ``stop_flags`` is
``reservations.stop_poses``. Nothing here allocates (the kernels compile without reference
counting, ``multicrane.vector.compiled``): scratch space comes in ``TaskScratch`` (``sc``) and
``SearchScratch`` (``ss``).
"""

from __future__ import annotations

from multicrane.tasks.distance_oracle import start_oracle
from multicrane.tasks.reservations import INF
from multicrane.tasks.search_kernels import path_rows_kernel, space_time_search_into
from multicrane.vector.compiled import inlined, kernel

IN_TRANSIT, INITIAL = 1, 0
SEARCHES, FAILED, EXPANSIONS, CLAIMS, REPLANS, REPAIRS = range(6)  # ``STAT_NAMES`` order


@inlined
def slot_of(tt, b, comp):
    """The slot of ``comp``'s plan, -1 when it has none."""
    for s in range(tt.slot_comp.shape[1]):
        if tt.slot_comp[b, s] == comp:
            return s
    return -1


@kernel
def in_order(tt, b, out):
    """The slots holding plans into ``out``, in the plans dict's order (insertion numbers);
    returns their count."""
    n = 0
    for s in range(tt.slot_comp.shape[1]):
        if tt.slot_comp[b, s] >= 0:
            i = n
            while i > 0 and tt.slot_order[b, out[i - 1]] > tt.slot_order[b, s]:
                out[i] = out[i - 1]
                i -= 1
            out[i] = s
            n += 1
    return n


@inlined
def arrival(tt, b, s):
    return tt.slot_t0[b, s] + tt.slot_len[b, s] - 1


@inlined
def position_at(tt, b, s, t):
    """``Plan.at(t)`` for ``t`` from the plan's start on: the position (the last one after
    the arrival)."""
    return tt.slot_pos[b, s, min(t - tt.slot_t0[b, s], tt.slot_len[b, s] - 1)]


@inlined
def move_at(tt, b, s, t):
    """``Plan.move_at(t)``: the position's change in step ``t + 1`` (0 after the arrival;
    before the start, Python's negative index as the plan's list gives it)."""
    n = tt.slot_len[b, s]
    i = t - tt.slot_t0[b, s]
    if i >= n - 1:
        return 0
    j = i + 1
    if i < 0:
        i += n
    if j < 0:
        j += n
    return tt.slot_pos[b, s, j] - tt.slot_pos[b, s, i]


@kernel
def put_plan(tt, b, comp, crane, target, t0, path, length, claim, counted):
    """Set ``comp``'s plan to ``path[:length]`` (``plans[comp] = plan``: a new key goes last,
    a present one keeps its place); ``counted``: give the component its creation number if it
    has none (``Carrier._new_plan``). False when no slot is free (never: a plan is a crane's)."""
    s = slot_of(tt, b, comp)
    if s < 0:
        for u in range(tt.slot_comp.shape[1]):
            if tt.slot_comp[b, u] < 0:
                s = u
                break
        if s < 0:
            return False
        tt.n_inserted[b] += 1
        tt.slot_order[b, s] = tt.n_inserted[b]
    tt.slot_comp[b, s] = comp
    tt.slot_crane[b, s] = crane
    tt.slot_target[b, s] = target
    tt.slot_t0[b, s] = t0
    tt.slot_claim[b, s] = claim
    tt.slot_len[b, s] = length
    for i in range(length):
        tt.slot_pos[b, s, i] = path[i]
    if counted and tt.seq[b, comp] == 0:
        tt.n_seq[b] += 1
        tt.seq[b, comp] = tt.n_seq[b]
    return True


@inlined
def rel_of(ts, comp):
    """The component's shape offsets (its lifted pose's, ``reservations.shape_of``)."""
    shape = ts.shape_of[comp]
    return ts.shape_rel[shape, : ts.shape_len[shape]]


@kernel
def table(ms, st, ts, tt, sc, b, T):
    """The reservations of every plan from time ``T`` on into ``sc.rows`` (module doc);
    returns their count."""
    rows = sc.rows
    n = 0
    for comp in range(len(ms.length)):
        if st.status[b, comp] != IN_TRANSIT:
            continue
        s = slot_of(tt, b, comp)
        if s < 0:
            for i in range(ms.length[comp]):
                rows[n, 0] = st.cells[b, comp, i]
                rows[n, 1] = T
                rows[n, 2] = INF
                rows[n, 3] = comp
                n += 1
        else:
            n = path_rows_kernel(rows, n, comp, rel_of(ts, comp), tt.slot_t0[b, s],
                                 tt.slot_pos[b, s, : tt.slot_len[b, s]], T, INF)  # fmt: skip
    for s in range(tt.slot_comp.shape[1]):
        comp = tt.slot_comp[b, s]
        if comp >= 0 and tt.slot_claim[b, s] and st.status[b, comp] == INITIAL:
            n = path_rows_kernel(rows, n, comp, rel_of(ts, comp), tt.slot_t0[b, s],
                                 tt.slot_pos[b, s, : tt.slot_len[b, s]], T, INF)  # fmt: skip
    return n


@kernel
def stop_flags(ms, st, ts, tt, sc, b, comp, target):
    """``reservations.stop_poses`` into ``sc.stop`` (a flag per position): goal poses of the
    component's other compatible targets that are free with every support filled or the
    target of another plan (a path entering one would arrive there)."""
    stop = sc.stop
    stop[:] = False
    shape = ts.shape_of[comp]
    for t in ms.compatible[comp]:
        if t < 0:
            break
        if t == target or st.filled_by[b, t] >= 0:
            continue
        ok = True
        for sup in ms.supports[t]:
            if sup < 0:
                break
            if st.filled_by[b, sup] >= 0:
                continue
            planned = False
            for s in range(tt.slot_comp.shape[1]):
                c = tt.slot_comp[b, s]
                if c >= 0 and c != comp and tt.slot_target[b, s] == sup:
                    planned = True
            if not planned:
                ok = False
                break
        if ok and ts.goal[shape, t] >= 0:
            stop[ts.goal[shape, t]] = True


@kernel
def search(ms, st, ts, tt, sc, ss, b, comp, start, t_start, goal, crane, claim, T):
    """``CarrierPlanning._search`` (stop poses in ``sc.stop``): the space-time A*, counted
    in ``stats``; the path's length (its positions in ``ss.path``), 0 when none."""
    tt.stats[b, SEARCHES] += 1
    shape = ts.shape_of[comp]
    rel = rel_of(ts, comp)
    reach = ts.reach_fit[shape, crane if ms.has_reach else 0]
    occ, status = st.occ[b], st.status[b]
    start_oracle(sc.oracle, occ, status, ms.static_occ, reach, rel, ts.coords, start, goal)
    n = table(ms, st, ts, tt, sc, b, T)
    length, expansions = space_time_search_into(
        sc.rows, n, comp, rel, start, t_start, goal, sc.stop, occ, status, ms.static_occ, reach,
        ts.coords, ms.move_delta, sc.oracle, ts.slack, ts.max_expansions, claim, INF, ss,
    )  # fmt: skip
    if length < 0:
        raise RuntimeError("task vector env: a search outgrew its scratch (a bug: its size "
                           "bounds every search)")  # fmt: skip
    tt.stats[b, EXPANSIONS] += expansions
    if length == 0:
        tt.stats[b, FAILED] += 1
    return length


@inlined
def reaches(ms, crane, cells, n):
    """``Site.reaches``: the crane's zone holds the first ``n`` cells (always without reach)."""
    if not ms.has_reach:
        return True
    for i in range(n):  # noqa: SIM110 (a loop: numba compiles no generators here)
        if not ms.zone[crane, cells[i]]:
            return False
    return True
