"""The paper process's rules for one copy, compiled: placing, arrival, the pointer, planes, masks.

Each function acts on copy ``b`` of a ``PaperState`` with the scenario's ``PaperSite``, as
``multicrane.sim.simulator.Simulator`` (one crane, ``auto=True``), ``multicrane.sim.legality``
and the ``Observer`` with ``PAPER_PLANES`` do for one site (docs/paper-spec.md sections 5-6).
``multicrane.vector.paper_step`` and ``multicrane.vector.paper_reset`` call them per copy.

The planes are a function of the state: a plan column's channels 1, 2, 4 and 5 follow from
the cells above it (``refresh_column``), so a step recomputes only the columns whose cells
changed, and channel 5 (``k`` on arrived cells) wherever an arrived component stands when
``k`` changes.
"""

from __future__ import annotations

from multicrane.core.codes import N_MOVES, Status
from multicrane.vector.compiled import inlined, kernel

INITIAL, IN_TRANSIT, ARRIVED, ASSEMBLED = (int(s) for s in Status)
CHANNELS = 6


@inlined
def fits(st, b, comp, cells, row):
    """Every cell of ``cells[b, row]`` is free or held by ``comp`` already."""
    own = comp + 1
    for i in range(cells.shape[2]):
        j = cells[b, row, i]
        if j < 0:
            break
        v = st.occ[b, j]
        if v != 0 and v != own:
            return False
    return True


@inlined
def move_ok(site, st, b, comp, cells, move):
    """The move of ``comp`` judged from ``cells[b, comp]`` (its cells or pick-up pose)."""
    d = site.move_delta[move]
    own = comp + 1
    for i in range(cells.shape[2]):
        j = cells[b, comp, i]
        if j < 0:
            break
        v = st.occ[b, j + d]
        if v != 0 and v != own:
            return False
    return True


@kernel
def _touch(site, buf, j, n_touched):
    """Note the plan column of cell ``j`` (once); returns the new count."""
    p = site.column_of[j]
    for i in range(n_touched):
        if buf.touched[i] == p:
            return n_touched
    buf.touched[n_touched] = p
    return n_touched + 1


@kernel
def place(site, st, buf, b, comp, source, delta, n_touched):
    """Move ``comp`` to ``source[b, comp] + delta`` (its pick-up pose, or its cells shifted);
    the plan columns of its old and new cells are noted in ``buf.touched``."""
    cells = st.cells
    for i in range(cells.shape[2]):
        j = cells[b, comp, i]
        if j < 0:
            break
        st.occ[b, j] = 0
        n_touched = _touch(site, buf, j, n_touched)
    for i in range(cells.shape[2]):
        j = source[b, comp, i]
        if j < 0:
            break
        j += delta
        cells[b, comp, i] = j
        st.occ[b, j] = comp + 1
        n_touched = _touch(site, buf, j, n_touched)
    return n_touched


@kernel
def target_ready(site, st, b, t):
    """The target is free and every support holds an assembled component."""
    if st.filled_by[b, t] >= 0:
        return False
    for s in site.supports[t]:
        if s < 0:
            break
        f = st.filled_by[b, s]
        if f < 0 or st.status[b, f] != ASSEMBLED:
            return False
    return True


@kernel
def has_ready_target(site, st, b, comp):
    for t in site.compatible[comp]:
        if t < 0:
            break
        if target_ready(site, st, b, t):
            return True
    return False


@kernel
def arrives(site, st, b, comp):
    """The component covers exactly a ready target it may fill: it is assembled at once
    (filled, the crane freed, ``N`` one more); True when it did."""
    t = site.target_at[st.cells[b, comp, 0]]
    if t < 0:
        return False
    compatible = False
    for u in site.compatible[comp]:
        if u == t:
            compatible = True
    if not compatible or site.length[t] != site.length[comp]:
        return False
    for i in range(site.length[comp]):
        j = st.cells[b, comp, i]
        inside = False
        for u in range(site.length[t]):
            if site.target_cells[t, u] == j:
                inside = True
        if not inside:
            return False
    if not target_ready(site, st, b, t):
        return False
    st.status[b, comp] = ASSEMBLED
    st.filled[b, comp] = t
    st.filled_by[b, t] = comp
    st.held[b] = -1
    st.n_assembled[b] += 1
    return True


@kernel
def assign(site, st, b):
    """The list pointer gives the idle crane its next component (docs/paper-spec.md section
    5, item 1); a pre-built entry reached the first time makes the next step a pass-over.
    Returns 1 when a component was assigned, else 0."""
    n = len(site.order)
    for _ in range(n):
        pos = st.pointer[b]
        comp = site.order[pos]
        st.pointer[b] = (pos + 1) % n
        if site.prebuilt[comp]:
            if not st.passed_over[b, comp]:
                st.passed_over[b, comp] = True
                st.pass_over[b] = True
                return 0
            continue
        if st.status[b, comp] != INITIAL:
            continue
        if site.waits[comp] and not has_ready_target(site, st, b, comp):
            continue
        st.held[b] = comp
        return 1
    return 0


@kernel
def refresh_column(site, st, obs, b, p, k):
    """Channels 1, 2, 4 and 5 of plan column ``p`` from the cells above it."""
    base = site.column_base[p]
    top_yard = 0  # channel 1: obstacles and initial components
    top_moved = 0  # channel 2: the component in transit and arrived ones
    over = 0
    at_target = 0
    for z in range(1, site.height + 1):
        v = st.occ[b, base + z]
        if v < 0:
            top_yard = z
        elif v > 0:
            s = st.status[b, v - 1]
            if s == INITIAL:
                top_yard = z
            else:
                top_moved = z
                if s == IN_TRANSIT:
                    if st.moves[b, v - 1] > site.move_limit:
                        over = 1
                else:
                    at_target = 1
    o = p * CHANNELS
    obs[b, o + 1] = top_yard
    obs[b, o + 2] = top_moved
    obs[b, o + 4] = over
    obs[b, o + 5] = at_target * k


@kernel
def rescale_arrived(site, st, obs, b, k):
    """Channel 5 is ``k`` wherever an arrived component stands: write it after ``k`` changed."""
    for c in range(st.status.shape[1]):
        if st.status[b, c] >= ARRIVED:
            for i in range(site.length[c]):
                obs[b, site.column_of[st.cells[b, c, i]] * CHANNELS + 5] = k


@kernel
def write_mask(site, st, masks, b):
    """``action_masks()`` of ``PaperAssemblyEnv(mask_blocked_moves=True)``: the moves that are
    not blocked; all six during a pass-over, with no component, or when all are blocked."""
    for m in range(N_MOVES):
        masks[b, m] = 1
    comp = st.held[b]
    if st.pass_over[b] or comp < 0:
        return
    status = st.status[b, comp]
    if status == IN_TRANSIT:
        source = st.cells
    elif status == INITIAL and fits(st, b, comp, st.pickup, comp):
        source = st.pickup
    else:
        return
    any_ok = False
    for m in range(N_MOVES):
        ok = move_ok(site, st, b, comp, source, m)
        masks[b, m] = ok
        any_ok |= ok
    if not any_ok:
        for m in range(N_MOVES):
            masks[b, m] = 1
