"""The multi-agent process's rules for one copy, compiled: claims, moves, assembly, legality.

Each function acts on copy ``b`` of a ``MotionState`` with the scenario's ``MotionSite`` as
``multicrane.sim.simulator.Simulator`` (``auto=False``) and ``multicrane.sim.legality`` do
for one site: ``act`` is ``Simulator._act`` for one crane, event for event, and
``write_masks`` is ``Legality.action_masks``. Site events enter as the state's present
(``st.delivered``, ``st.down``, ``st.closed`` while ``st.closing``): a crane that is down may
only wait, a component off site cannot be claimed, no component cell enters or leaves a
closed cell, and a target with a closed cell is not ready. Readiness of targets is
kept in the state (``refresh_ready`` after every arrival and assembly, as the simulator's
``_update_targets``). Whatever a rule changes is noted for the observation: the component
(``buf.changed``) and the plan columns of the cells it left or took (``buf.dirty``).
"""

from __future__ import annotations

from multicrane.core.codes import ASSEMBLE, CLAIM_BASE, N_MOVES, WAIT, EventType
from multicrane.vector import paper_rules
from multicrane.vector.compiled import inlined, kernel
from multicrane.vector.paper_rules import ARRIVED, ASSEMBLED, IN_TRANSIT, INITIAL

_CLAIMED = int(EventType.CLAIMED)
_LIFTED = int(EventType.LIFTED)
_BLOCKED = int(EventType.BLOCKED)
_LIFT_BLOCKED = int(EventType.LIFT_BLOCKED)
_CLAIM_CONFLICT = int(EventType.CLAIM_CONFLICT)
_ARRIVED = int(EventType.ARRIVED)
_ASSEMBLY_STARTED = int(EventType.ASSEMBLY_STARTED)
_ASSEMBLED = int(EventType.ASSEMBLED)
_ILLEGAL = int(EventType.ILLEGAL)


@inlined
def mark_column(site, buf, j):
    """Note the plan column of cell ``j`` for the observation (once per step)."""
    p = site.column_of[j]
    if not buf.dirty[p]:
        buf.dirty[p] = True
        buf.dirty_list[buf.n_dirty[0]] = p
        buf.n_dirty[0] += 1


@inlined
def mark_component(site, st, buf, b, comp):
    """Note a component whose cells or status changed, and the columns it stands in."""
    buf.changed[comp] = True
    for i in range(site.length[comp]):
        mark_column(site, buf, st.cells[b, comp, i])


@kernel
def refresh_ready(site, st, buf, b):
    """Target readiness and, per component, whether a compatible target is ready (noted in
    ``buf.ready_changed``)."""
    buf.ready_changed[0] = True
    C = len(site.length)
    for t in range(C):
        st.target_ready[b, t] = paper_rules.target_ready(site, st, b, t) and (
            not st.closing[b] or open_cells(st, b, site.target_cells[t])
        )
    for c in range(C):
        ready = False
        for t in site.compatible[c]:
            if t < 0:
                break
            ready |= st.target_ready[b, t]
        st.has_ready[b, c] = ready


@inlined
def open_cells(st, b, cells):
    """``Legality.open_cells``: no cell of the -1 padded row ``cells`` is closed now."""
    for j in cells:
        if j < 0:
            break
        if st.closed[b, j]:
            return False
    return True


@inlined
def lift_ok(st, b, comp):
    """``Legality._lift_ok``: the pick-up pose is free, and neither it nor the component's
    cells are closed."""
    if not paper_rules.fits(st, b, comp, st.pickup, comp):
        return False
    return not st.closing[b] or (
        open_cells(st, b, st.pickup[b, comp]) and open_cells(st, b, st.cells[b, comp])
    )


@inlined
def _place(site, st, buf, b, comp, source, delta):
    """Move ``comp`` to ``source[b, comp] + delta`` (its pick-up pose, or its cells moved)."""
    cells = st.cells
    for i in range(site.length[comp]):
        j = cells[b, comp, i]
        st.occ[b, j] = 0
        mark_column(site, buf, j)
    for i in range(site.length[comp]):
        j = source[b, comp, i] + delta
        cells[b, comp, i] = j
        st.occ[b, j] = comp + 1
        mark_column(site, buf, j)
    buf.changed[comp] = True


@inlined
def in_reach(site, st, b, crane, comp):
    """``Legality.in_reach``: the pick-up pose is in the crane's zone and a compatible target
    there is free (a waiting component's: ready). Always True without reach."""
    if not site.has_reach:
        return True
    if not st.pickup_in_zone[b, crane, comp]:
        return False
    for t in site.zone_targets[crane, comp]:
        if t < 0:
            break
        if st.target_ready[b, t] if site.waits[comp] else st.filled_by[b, t] < 0:
            return True
    return False


@inlined
def move_allowed(site, st, b, crane, comp, move):
    """The move of an in-transit component is not blocked and stays in the crane's zone."""
    if not paper_rules.move_ok(site, st, b, comp, st.cells, move):
        return False
    if st.closing[b]:
        d = site.move_delta[move]
        for i in range(site.length[comp]):
            j = st.cells[b, comp, i]
            if st.closed[b, j] or st.closed[b, j + d]:
                return False
    if site.has_reach:
        d = site.move_delta[move]
        for i in range(site.length[comp]):
            if not site.zone[crane, st.cells[b, comp, i] + d]:
                return False
    return True


@inlined
def claimable(site, st, b, comp):
    """``Legality.claimable``: initial, unclaimed, on site, its pick-up pose free and open,
    somewhere to go."""
    return (
        st.status[b, comp] == INITIAL
        and st.holder[b, comp] < 0
        and st.delivered[b, comp]
        and lift_ok(st, b, comp)
        and (not site.waits[comp] or st.has_ready[b, comp])
    )


@inlined
def _arrival(site, st, buf, b, crane, comp):
    """``Simulator._check_arrival``: on a ready compatible target it may fill, it arrives."""
    t = site.target_at[st.cells[b, comp, 0]]
    if t < 0:
        return
    compatible = False
    for u in site.compatible[comp]:
        compatible |= u == t
    if not compatible or site.length[t] != site.length[comp]:
        return
    for i in range(site.length[comp]):
        if site.target_at[st.cells[b, comp, i]] != t:
            return
    if not st.target_ready[b, t]:
        return
    st.status[b, comp] = ARRIVED
    st.filled[b, comp] = t
    st.filled_by[b, t] = comp
    refresh_ready(site, st, buf, b)
    buf.event_counts[b, crane, _ARRIVED] += 1


@inlined
def _continue_assembly(site, st, buf, b, crane):
    st.assembling[b, crane] -= 1
    if st.assembling[b, crane] != 0:
        return
    comp = st.held[b, crane]
    st.status[b, comp] = ASSEMBLED
    st.holder[b, comp] = -1
    st.held[b, crane] = -1
    st.n_assembled[b] += 1
    mark_component(site, st, buf, b, comp)
    refresh_ready(site, st, buf, b)
    buf.event_counts[b, crane, _ASSEMBLED] += 1
    buf.progress_by[buf.n_progress[0]] = crane
    buf.n_progress[0] += 1


@inlined
def _claim(site, st, buf, b, crane, comp):
    """``Simulator._claim`` (multi-agent mode): the checks in its order, then the lift."""
    events = buf.event_counts
    if st.held[b, crane] >= 0:
        events[b, crane, _ILLEGAL] += 1
    elif st.holder[b, comp] >= 0 and st.status[b, comp] != ASSEMBLED:
        events[b, crane, _CLAIM_CONFLICT] += 1
    elif (
        st.status[b, comp] != INITIAL
        or (site.waits[comp] and not st.has_ready[b, comp])
        or not st.delivered[b, comp]
        or not in_reach(site, st, b, crane, comp)
    ):
        events[b, crane, _ILLEGAL] += 1
    elif not lift_ok(st, b, comp):
        events[b, crane, _LIFT_BLOCKED] += 1
    else:
        events[b, crane, _CLAIMED] += 1
        st.held[b, crane] = comp
        _place(site, st, buf, b, comp, st.pickup, 0)
        st.status[b, comp] = IN_TRANSIT
        st.holder[b, comp] = crane
        events[b, crane, _LIFTED] += 1
        _arrival(site, st, buf, b, crane, comp)


@inlined
def act(site, st, buf, b, crane, action):
    """One crane's action (``Simulator._act`` with ``auto=False``; a held component is never
    initial there, since a claim lifts it at once)."""
    events = buf.event_counts
    if st.down[b, crane]:  # broken down: only wait; an assembly pauses, a load stays
        if action != WAIT:
            events[b, crane, _ILLEGAL] += 1
        return
    if st.assembling[b, crane] != 0:
        if action != WAIT:
            events[b, crane, _ILLEGAL] += 1
        _continue_assembly(site, st, buf, b, crane)
        return
    comp = st.held[b, crane]
    if action < N_MOVES:
        if comp < 0 or st.status[b, comp] == ARRIVED:
            events[b, crane, _ILLEGAL] += 1
        elif not move_allowed(site, st, b, crane, comp, action):
            events[b, crane, _BLOCKED] += 1
        else:
            _place(site, st, buf, b, comp, st.cells, site.move_delta[action])
            st.moves[b, comp] += 1
            _arrival(site, st, buf, b, crane, comp)
    elif action == ASSEMBLE:
        if comp < 0 or st.status[b, comp] != ARRIVED:
            events[b, crane, _ILLEGAL] += 1
            return
        st.assembling[b, crane] = site.assembly_steps
        events[b, crane, _ASSEMBLY_STARTED] += 1
        _continue_assembly(site, st, buf, b, crane)
    elif action != WAIT:
        _claim(site, st, buf, b, crane, action - CLAIM_BASE)


@inlined
def write_masks(site, st, masks, b):
    """``Legality.action_masks`` of every crane (``st.claimable`` is up to date)."""
    C = len(site.length)
    for k in range(site.n_cranes):
        for a in range(masks.shape[2]):
            masks[b, k, a] = 0
        masks[b, k, WAIT] = 1
        if st.assembling[b, k] != 0 or st.down[b, k]:
            continue
        comp = st.held[b, k]
        if comp < 0:
            for c in range(C):
                if st.claimable[b, c] and in_reach(site, st, b, k, c):
                    masks[b, k, CLAIM_BASE + c] = 1
        elif st.status[b, comp] == ARRIVED:
            masks[b, k, ASSEMBLE] = 1
        elif st.status[b, comp] == IN_TRANSIT:
            for m in range(N_MOVES):
                masks[b, k, m] = move_allowed(site, st, b, k, comp, m)
