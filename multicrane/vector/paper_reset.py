"""Resets in kernels: a copy's start drawn as ``multicrane.sim.start.draw_start`` draws it.

``draw_start`` takes the same numbers from the copy's generator in the same order as the
Python function does with a ``np.random.Generator`` in the same state: first the target of
each pre-built component that may stand on several (``integers``), then, in list order, each
randomly placed component's pose among its free candidates (``choice`` with the renormalised
weights), the whole layout drawn again when one finds no free pose. ``lay_out`` puts the
components where it drew them (both modes' resets call it); ``reset_copy`` then builds the
episode's state as ``SiteState.at_start`` and ``Simulator.reset`` do, gives the crane its
first component, and writes the observation and mask.
"""

from __future__ import annotations

import numpy as np

from multicrane.sim.start import MAX_START_ATTEMPTS
from multicrane.vector import paper_rules as rules
from multicrane.vector.compiled import kernel
from multicrane.vector.pcg64 import bounded, choice


@kernel
def _draw_prebuilt(site, st, buf, b):
    """The target of every pre-built component into ``buf.chosen``; False when one has no
    free target left."""
    C = len(site.prebuilt)
    for i in range(C):
        buf.chosen[i] = -1
        if site.prebuilt[i] and site.prebuilt_on[i, 0] < 0:
            buf.chosen[i] = i
    for i in range(C):
        if not site.prebuilt[i] or site.prebuilt_on[i, 0] < 0:
            continue
        n = 0
        for t in site.prebuilt_on[i]:
            if t >= 0 and not _taken(buf.chosen, t):
                n += 1
        if n == 0:
            return False
        pick = bounded(st.rng, b, n)
        for t in site.prebuilt_on[i]:
            if t >= 0 and not _taken(buf.chosen, t):
                if pick == 0:
                    buf.chosen[i] = t
                    break
                pick -= 1
    return True


@kernel
def _taken(chosen, t):
    found = False
    for u in chosen:
        found |= u == t
    return found


@kernel
def _draw_layout(site, st, buf, b):
    """One attempt at the random poses (candidate rows into ``buf.chosen``); False when a
    component finds every candidate taken."""
    for j in range(len(buf.occupied)):
        buf.occupied[j] = site.fixed_occ[j]
    L = site.cand_cells.shape[1]
    for i in site.drawn:
        table = site.table_of[i]
        start, stop = site.table_start[table], site.table_start[table + 1]
        any_free = False
        for r in range(start, stop):
            free = True
            for u in range(L):
                j = site.cand_cells[r, u]
                if j >= 0 and buf.occupied[j]:
                    free = False
                    break
            buf.weights[r - start] = site.cand_prob[r] if free else 0.0
            any_free |= free
        if not any_free:
            return False
        row = start + choice(
            st.rng, b, buf.weights, stop - start, buf.cdf, buf.frames, buf.partial
        )
        for u in range(L):
            j = site.cand_cells[row, u]
            if j >= 0:
                buf.occupied[j] = True
        buf.chosen[i] = row
    return True


@kernel
def draw_start(site, st, buf, b):
    """Each component's start into ``buf.chosen`` (pre-built: its target; drawn: its
    candidate row; fixed: unused). False when no start was found (the scenario's fault:
    ``draw_start`` raises ``ScenarioError`` there)."""
    if not _draw_prebuilt(site, st, buf, b):
        return False
    if len(site.drawn) == 0:
        return True
    found, attempts = False, 0
    while not found and attempts < MAX_START_ATTEMPTS:
        found = _draw_layout(site, st, buf, b)
        attempts += 1
    return found


@kernel
def lay_out(site, st, buf, b):
    """Every component's cells, pick-up pose, status, target and move count at the start
    drawn in ``buf.chosen`` (``SiteState.at_start``), and the grid's occupancy."""
    C, L = site.target_cells.shape
    for j in range(len(site.static_occ)):
        st.occ[b, j] = site.static_occ[j]
    for i in range(C):
        st.moves[b, i] = 0
        st.filled[b, i] = -1
        st.filled_by[b, i] = -1
    for i in range(C):
        t = buf.chosen[i] if site.prebuilt[i] else -1
        for u in range(L):
            if t >= 0:  # pre-built: assembled on its target from the start
                st.cells[b, i, u] = site.target_cells[t, u]
                st.pickup[b, i, u] = -1
            elif site.table_of[i] >= 0:
                st.cells[b, i, u] = site.cand_cells[buf.chosen[i], u]
                st.pickup[b, i, u] = site.cand_pickup[buf.chosen[i], u]
            else:
                st.cells[b, i, u] = site.fixed_cells[i, u]
                st.pickup[b, i, u] = site.fixed_pickup[i, u]
            j = st.cells[b, i, u]
            if j >= 0:
                st.occ[b, j] = i + 1
        if t >= 0:
            st.status[b, i] = rules.ASSEMBLED
            st.filled[b, i] = t
            st.filled_by[b, t] = i
        else:
            st.status[b, i] = rules.INITIAL


@kernel
def reset_copy(site, st, buf, b, mask_blocked):
    """Start a new episode in copy ``b`` from its generator; False when no start is found."""
    if not draw_start(site, st, buf, b):
        return False
    lay_out(site, st, buf, b)
    for i in range(len(site.prebuilt)):
        st.passed_over[b, i] = False
    st.held[b] = -1
    st.pass_over[b] = False
    st.pointer[b] = 0
    st.n_assembled[b] = site.n_prebuilt
    st.step_count[b] = 0
    rules.assign(site, st, b)
    for i in range(len(site.obs_template)):
        buf.obs[b, i] = site.obs_template[i]
    for c in range(st.cells.shape[1]):
        for u in range(st.cells.shape[2]):
            j = st.cells[b, c, u]
            if j >= 0:
                rules.refresh_column(site, st, buf.obs, b, site.column_of[j], 0)
    if mask_blocked:
        rules.write_mask(site, st, buf.masks, b)
    buf.component_index[b] = st.held[b]
    return True


@kernel
def reset_copies(site, st, buf, which, mask_blocked):
    """Reset every copy with ``which[b]``; returns the first copy with no start, else -1."""
    for b in range(len(which)):
        if which[b] and not reset_copy(site, st, buf, b, mask_blocked):
            return b
    return -1


def reset_all(site, st, buf, mask_blocked: bool) -> int:
    """Reset every copy (see ``reset_copies``)."""
    return reset_copies(site, st, buf, np.ones(len(st.held), dtype=bool), mask_blocked)
