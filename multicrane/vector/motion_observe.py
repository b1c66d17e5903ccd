"""The motion mode's observations in kernels: every crane's vector, written where it changed.

The layout is ``multicrane.envs.observation``'s (``MULTI_AGENT_PLANES``): seven shared
planes, two per-crane planes, the component table, the crane vector and, with site events,
the events block (``motion_events.write_events_block``), one ``[N, D]`` block per copy. A
component off site (not delivered yet) holds no cell and its table row is all zero. The
shared planes and the table are a function of the state, so a step recomputes only the plan
columns the rules marked (``buf.dirty``) and the table rows of the components they marked
(``buf.changed``), plus those whose claimability flipped, and writes them into every crane's
row. Claimability is rechecked only where it may have changed (the component changed, target
readiness was refreshed, or a pick-up cell's column is dirty). A crane's own planes are
repainted only when they change: its component's plane when it holds another component or
that one moved, its targets' plane when it holds another or target readiness was refreshed;
its crane vector is rewritten every step.
"""

from __future__ import annotations

from multicrane.envs.observation import COMPONENT_FEATURES, N_OWN, N_SHARED
from multicrane.vector.compiled import inlined, kernel
from multicrane.vector.motion_events import write_events_block
from multicrane.vector.motion_rules import claimable, mark_component
from multicrane.vector.paper_rules import ARRIVED, ASSEMBLED, IN_TRANSIT, INITIAL

_OBSTACLE, _INITIAL, _READY, _IN_TRANSIT, _AT_TARGET, _FREE_TARGET, _OVER_LIMIT = range(N_SHARED)


@inlined
def _may_flip(site, st, buf, b, c):
    """Whether component ``c``'s claimability may have changed in this step: it changed,
    readiness was refreshed, or one of its pick-up cells lies in a dirty column."""
    if buf.changed[c] or buf.ready_changed[0]:
        return True
    if st.status[b, c] != INITIAL:
        return False
    for i in range(st.pickup.shape[2]):
        j = st.pickup[b, c, i]
        if j < 0:
            break
        if buf.dirty[site.column_of[j]]:
            return True
    return False


@inlined
def refresh_claimable(site, st, buf, b):
    """Claimability of every component now; a component whose flag flipped is repainted."""
    for c in range(len(site.length)):
        if not _may_flip(site, st, buf, b, c):
            continue
        now = claimable(site, st, b, c)
        if now != st.claimable[b, c]:
            st.claimable[b, c] = now
            mark_component(site, st, buf, b, c)


@inlined
def _write_row(site, st, obs, b, c):
    """Component ``c``'s table row in every crane's observation (zero while off site)."""
    o = site.rows_start + c * COMPONENT_FEATURES
    if not st.delivered[b, c]:
        for k in range(site.n_cranes):
            for i in range(COMPONENT_FEATURES):
                obs[b, k, o + i] = 0.0
        return
    s = st.status[b, c]
    last = st.cells[b, c, site.length[c] - 1]
    first = st.cells[b, c, 0]
    for k in range(site.n_cranes):
        obs[b, k, o] = s == INITIAL
        obs[b, k, o + 1] = s == IN_TRANSIT
        obs[b, k, o + 2] = s == ARRIVED
        obs[b, k, o + 3] = s == ASSEMBLED
        obs[b, k, o + 4] = st.claimable[b, c]
        obs[b, k, o + 5] = st.holder[b, c] >= 0
        obs[b, k, o + 6] = st.held[b, k] == c
        obs[b, k, o + 7] = site.beam[c]
        for a in range(3):
            obs[b, k, o + 8 + a] = site.scaled[first, a]
            obs[b, k, o + 11 + a] = site.scaled[last, a]


@inlined
def _refresh_column(site, st, buf, b, p):
    """The seven shared planes of plan column ``p`` from the cells above it, into every
    crane's observation: each holds the top height of a cell that qualifies."""
    tops = buf.tops
    for f in range(N_SHARED):
        tops[f] = 0
    base = site.column_base[p]
    for z in range(1, site.height + 1):
        j = base + z
        v = st.occ[b, j]
        if v < 0:
            if site.obstacle[j]:
                tops[_OBSTACLE] = z
        elif v > 0:
            c = v - 1
            s = st.status[b, c]
            if s == INITIAL:
                tops[_INITIAL] = z
                if st.claimable[b, c]:
                    tops[_READY] = z
            elif s == IN_TRANSIT:
                tops[_IN_TRANSIT] = z
                if st.moves[b, c] > site.move_limit:
                    tops[_OVER_LIMIT] = z
            else:
                tops[_AT_TARGET] = z
        t = site.target_at[j]
        if t >= 0 and st.filled_by[b, t] < 0:
            tops[_FREE_TARGET] = z
    o = p * N_SHARED
    for k in range(site.n_cranes):
        for f in range(N_SHARED):
            buf.obs[b, k, o + f] = site.plane_z[tops[f]]


@inlined
def _own_plane(site, buf, b, k, j, channel):
    """Raise one per-crane plane entry to the height of cell ``j`` (noted for clearing)."""
    i = site.own_start + site.column_of[j] * N_OWN + channel
    value = site.own_z[site.z_of[j]]
    if value > buf.obs[b, k, i]:
        buf.obs[b, k, i] = value
    slot = channel * site.target_cells.shape[1] + buf.own_count[b, k, channel]
    buf.own_written[b, k, slot] = i
    buf.own_count[b, k, channel] += 1


@inlined
def _clear_own(site, buf, b, k, channel):
    """Zero the entries of crane ``k``'s plane ``channel`` that were set."""
    first = channel * site.target_cells.shape[1]
    for n in range(buf.own_count[b, k, channel]):
        buf.obs[b, k, buf.own_written[b, k, first + n]] = 0.0
    buf.own_count[b, k, channel] = 0


@inlined
def _write_own(site, st, buf, b, k, force):
    """Crane ``k``'s planes (its component, the targets it could fill now), where they
    changed (everywhere with ``force``), and its vector."""
    obs = buf.obs
    comp = st.held[b, k]
    other = force or comp != buf.own_comp[b, k]
    buf.own_comp[b, k] = comp
    if other or (comp >= 0 and buf.changed[comp]):
        _clear_own(site, buf, b, k, 0)
        if comp >= 0:
            for i in range(site.length[comp]):
                _own_plane(site, buf, b, k, st.cells[b, comp, i], 0)
    if other or buf.ready_changed[0]:
        _clear_own(site, buf, b, k, 1)
        if comp >= 0:
            for t in site.compatible[comp]:
                if t < 0:
                    break
                if st.target_ready[b, t]:
                    for i in range(site.length[t]):
                        _own_plane(site, buf, b, k, site.target_cells[t, i], 1)
    v = site.crane_start
    den = site.crane_den  # the fractions' divisors (1 in whole numbers, but the step's)
    if comp >= 0:
        s = st.status[b, comp]
        moves = st.moves[b, comp]
        obs[b, k, v] = 1.0
        obs[b, k, v + 1] = s == IN_TRANSIT
        obs[b, k, v + 2] = s == ARRIVED
        obs[b, k, v + 3] = min(moves, site.ratio_limit) / den[0]
        obs[b, k, v + 4] = moves > site.move_limit
    else:
        for i in range(5):
            obs[b, k, v + i] = 0.0
    obs[b, k, v + 5] = st.assembling[b, k] / den[1]
    obs[b, k, v + 6] = 0.0  # pass-over: the automatic mode's only
    obs[b, k, v + 7] = st.n_assembled[b] / den[2]
    obs[b, k, v + 8] = min(st.step_count[b], site.step_limit) * site.step_num / den[3]


@inlined
def observe_step(site, st, buf, b):
    """Bring copy ``b``'s observations up to date after its step (the rules marked what
    changed)."""
    refresh_claimable(site, st, buf, b)
    for k in range(site.n_cranes):
        _write_own(site, st, buf, b, k, False)
    buf.ready_changed[0] = False
    for c in range(len(site.length)):
        if buf.changed[c]:
            buf.changed[c] = False
            _write_row(site, st, buf.obs, b, c)
    for n in range(buf.n_dirty[0]):
        p = buf.dirty_list[n]
        buf.dirty[p] = False
        _refresh_column(site, st, buf, b, p)
    buf.n_dirty[0] = 0
    if site.has_events:
        write_events_block(site, st, buf, b, False)


@kernel
def observe_reset(site, st, buf, b):
    """Copy ``b``'s observations from scratch (after a reset)."""
    for k in range(site.n_cranes):
        for i in range(site.obs_size):
            buf.obs[b, k, i] = 0.0
        buf.own_count[b, k, 0] = 0
        buf.own_count[b, k, 1] = 0
    for c in range(len(site.length)):
        st.claimable[b, c] = claimable(site, st, b, c)
        buf.changed[c] = False
        _write_row(site, st, buf.obs, b, c)
    for p in range(len(site.column_base)):
        buf.dirty[p] = False
        _refresh_column(site, st, buf, b, p)
    buf.n_dirty[0] = 0
    for k in range(site.n_cranes):
        _write_own(site, st, buf, b, k, True)
    buf.ready_changed[0] = False
    if site.has_events:
        write_events_block(site, st, buf, b, True)
