"""Compiled kernels of the carrier's searches: the space-time A* and the scans of its table.

The reservations here are flat rows ``(cell, from, to, component)`` (``ReservationArrays``,
``multicrane.tasks.reservation_arrays``), positions and shapes are linear indices of the padded
grid, exactly as in ``multicrane.tasks.reservations``, whose Python ``space_time_search`` is the
specification: ``space_time_search_into`` follows it step for step (the same heap order, so
the same states expanded in the same order, the same path and the same count of expansions;
``tests/tasks/test_search_kernels.py`` compares them). Where the specification reads whole fit
and distance arrays, the kernel asks the site and a distance oracle at the positions it
reaches (``multicrane.tasks.distance_oracle``). Plain arrays in, and a ``SearchScratch`` to
work in (``multicrane.tasks.search_scratch``: nothing here allocates, so the kernels compile
without numba's reference counting and compiled callers that must not allocate call them
too); numba ``cache=True``, so a second process loads the machine code.
"""

from __future__ import annotations

import numba
import numpy as np

from multicrane.tasks.distance_oracle import CLOSED, fits_base, resume
from multicrane.tasks.search_scratch import (
    _FIRST_TABLE,
    ROOM_HEAP,
    ROOM_PATH,
    ROOM_ROWS,
    ROOM_TABLE,
)

CELL, FROM, TO, OWNER = range(4)  # the columns of a reservation row
_kernel = numba.njit(cache=True, _nrt=False)  # (module doc)


@_kernel
def conflict_kernel(rows, n_rows, cells, lo, hi, me):
    """Another owner than ``me`` holds one of ``cells`` at some time in ``lo..hi``."""
    for i in range(n_rows):
        if rows[i, OWNER] != me and rows[i, FROM] <= hi and rows[i, TO] >= lo:
            c = rows[i, CELL]
            for j in cells:
                if c == j:
                    return True
    return False


@_kernel
def path_rows_kernel(rows, n_rows, comp, rel, t0, positions, T, inf):
    """Append the rows of a path (``positions[i]`` at ``t0 + i``) from time ``T`` on, its
    last position held until ``inf``, after row ``n_rows``; returns the new row count. The
    rows hold room for ``len(positions) * len(rel)`` more."""
    n = positions.size
    i = max(0, T - t0)
    while i < n:
        k = i
        while k + 1 < n and positions[k + 1] == positions[i]:
            k += 1
        end = inf if k == n - 1 else t0 + k
        for r in rel:
            rows[n_rows, CELL] = positions[i] + r
            rows[n_rows, FROM] = t0 + i
            rows[n_rows, TO] = end
            rows[n_rows, OWNER] = comp
            n_rows += 1
        i = k + 1
    return n_rows


@_kernel
def goal_free_from_kernel(rows, n_rows, comp, rel, goal, t_start, inf):
    """``reservations.goal_free_from``: the first time from ``t_start`` on after which no
    other owner holds the goal's cells; -1 when one holds them for ever."""
    free_from = t_start
    for i in range(n_rows):
        if rows[i, OWNER] == comp:
            continue
        c = rows[i, CELL]
        for r in rel:
            if c == goal + r:
                if rows[i, TO] >= inf:
                    return -1
                free_from = max(free_from, rows[i, TO] + 1)
    return free_from


@_kernel
def _cell_lists(rows, n_rows, comp, t_start, head, nxt):
    """Per cell, a linked list (``head``, a cell's first row, and ``nxt``, each row's next;
    -1 ends) of the rows that can conflict with ``comp``'s search: other owners, holding
    until ``t_start`` or later (every query asks about ``t_start`` on)."""
    n_cells = head.size
    head[:] = -1
    for i in range(n_rows):
        c = rows[i, CELL]
        if rows[i, OWNER] != comp and rows[i, TO] >= t_start and 0 <= c < n_cells:
            nxt[i] = head[c]
            head[c] = i


@_kernel
def _held(rows, head, nxt, rel, p, lo, hi):
    """Some listed row holds a cell of the shape at position ``p`` at a time in ``lo..hi``."""
    n_cells = head.size
    for r in rel:
        c = p + r
        if c < 0 or c >= n_cells:
            continue
        i = head[c]
        while i >= 0:
            if rows[i, FROM] <= hi and rows[i, TO] >= lo:
                return True
            i = nxt[i]
    return False


@_kernel
def space_time_search_into(
    rows, n_rows, comp, rel, start, t_start, goal, stop, occ, status, static, reach, coords,
    deltas, oracle, slack, max_expansions, lifted_onto_goal_arrives, inf, scratch,
):  # fmt: skip
    """``reservations.space_time_search`` on flat reservation rows, in ``scratch``: (the
    path's length, its positions in ``scratch.path``, 0 when none, or a ``ROOM_*`` code when
    an array of ``scratch`` is too small for this search; the states expanded). ``stop``: a
    flag per position (the stop poses); the fit is ``distance_oracle.fits_base`` of ``occ``,
    ``status`` and ``reach``, and the distances to the goal are the ``oracle``'s, which reads
    the site's arrays given here."""
    site = (occ, status, static, reach, rel, coords, deltas)
    if not fits_base(occ, status, reach, rel, goal):
        return 0, 0
    free_from = goal_free_from_kernel(rows, n_rows, comp, rel, goal, t_start, inf)
    if free_from < 0:
        return 0, 0
    h0 = resume(oracle, *site, start)
    if h0 < 0:
        return 0, 0
    if start == goal and lifted_onto_goal_arrives:
        if t_start < free_from:
            return 0, 0
        scratch.path[0] = start
        return 1, 0
    t_cap = t_start + h0 + slack
    if free_from >= t_cap:  # held up to the time cap: no arrival in time (specification)
        return 0, 0
    if n_rows > scratch.nxt.size:
        return ROOM_ROWS, 0
    head, nxt = scratch.head[: stop.size], scratch.nxt
    _cell_lists(rows, n_rows, comp, t_start, head, nxt)
    below = free_from - t_start  # no arrival before: every state of lower f comes first
    if below > h0 and _states_below(
        rows, head, nxt, rel, start, t_start, goal, stop, site, oracle, below, max_expansions,
        scratch,
    ) > max_expansions:  # fmt: skip
        return 0, max_expansions + 1  # the A* stops at its cap
    return _astar(
        rows, head, nxt, rel, start, t_start, goal, stop, site, oracle, t_cap, free_from,
        max_expansions, scratch,
    )  # fmt: skip


@_kernel
def _states_below(
    rows, head, nxt, rel, start, t_start, goal, stop, site, oracle, below, limit, scratch,
):  # fmt: skip
    """How many states ``(p, t)`` with ``f = t - t_start + h[p] < below`` the A* reaches,
    counted up to ``limit + 1``: time layer by time layer, by the A*'s own moves and checks.

    With a consistent heuristic ``f`` never falls along a path, so these are the states
    reachable through states of lower ``f`` only, and the A* expands every one of them before
    any state of ``f >= below``. When ``below`` is at most the goal's ``f`` (the goal is not
    free before ``t_start + below``), the A* expands them all before it finds the goal: more
    than ``limit`` of them and it stops at its cap without a path."""
    occ, status, _, reach, _, _, deltas = site
    n = stop.size
    dist, mark = oracle[:n], oracle[n : 2 * n]
    layer_of = scratch.layer_of[:n]  # the last layer a position was put in
    layer_of[:] = -1
    layer, after = scratch.layer[:n], scratch.after[:n]
    layer[0] = start
    size, count, g = 1, 0, 0
    while size:
        count += size
        if count > limit:
            return count
        t = t_start + g
        t1, g1 = t + 1, g + 1
        grown = 0
        for k in range(size):
            p = layer[k]
            if _held(rows, head, nxt, rel, p, t1, t1):
                continue  # the A* expands nothing from here
            if p != goal and g1 + dist[p] < below and layer_of[p] != g1:  # wait (p: closed)
                layer_of[p] = g1
                after[grown] = p
                grown += 1
            for d in deltas:
                q = p + d
                if q < 0 or q >= n or stop[q] or q == goal or not fits_base(
                        occ, status, reach, rel, q):  # fmt: skip
                    continue
                hq = np.int64(dist[q]) if mark[q] == CLOSED else resume(oracle, *site, q)
                if hq < 0 or g1 + hq >= below or layer_of[q] == g1:
                    continue
                if _held(rows, head, nxt, rel, q, t, t1):
                    continue
                layer_of[q] = g1
                after[grown] = q
                grown += 1
        layer, after = after, layer
        size, g = grown, g1
    return count


_EMPTY = -1  # a free slot of the state table (state keys are never negative)
_MIX = np.uint64(0x9E3779B97F4A7C15)  # Fibonacci hashing: spreads consecutive keys


@numba.njit(cache=True, _nrt=False, inline="always")
def _slot(keys, key, mask):
    """The slot of ``key`` in the open-addressing table ``keys`` (linear probing): where it
    is, or the free slot where it goes."""
    i = np.int64((np.uint64(key) * _MIX) >> np.uint64(20)) & mask
    while keys[i] != _EMPTY and keys[i] != key:
        i = (i + 1) & mask
    return i


@_kernel
def _grow(scratch, table, size):
    """Move the state table of buffer ``table`` (``size`` slots) into the other buffer at
    twice the size; returns False when the scratch has no room for it."""
    if 2 * size > scratch.keys.shape[1]:
        return False
    old_keys, old_parents = scratch.keys[table], scratch.parents[table]
    keys, parents = scratch.keys[1 - table, : 2 * size], scratch.parents[1 - table, : 2 * size]
    keys[:] = _EMPTY
    mask = 2 * size - 1
    for i in range(size):
        if old_keys[i] != _EMPTY:
            j = _slot(keys, old_keys[i], mask)
            keys[j] = old_keys[i]
            parents[j] = old_parents[i]
    return True


@_kernel
def _push(levels, sizes, level, key):
    """Add ``key`` to the binary min-heap ``levels[level, :sizes[level]]``; False when the
    heap is full."""
    size = sizes[level]
    if size == levels.shape[1]:
        return False
    heap = levels[level]
    i = size
    while i > 0:
        up = (i - 1) >> 1
        if heap[up] <= key:
            break
        heap[i] = heap[up]
        i = up
    heap[i] = key
    sizes[level] = size + 1
    return True


@_kernel
def _pop(levels, sizes, level):
    """Remove and return the least key of the heap ``levels[level, :sizes[level]]``."""
    heap = levels[level]
    size = sizes[level] - 1
    sizes[level] = size
    top, last = heap[0], heap[size]
    i = 0
    while True:
        child = 2 * i + 1
        if child >= size:
            break
        if child + 1 < size and heap[child + 1] < heap[child]:
            child += 1
        if last <= heap[child]:
            break
        heap[i] = heap[child]
        i = child
    heap[i] = last
    return top


@_kernel
def _astar(
    rows, head, nxt, rel, start, t_start, goal, stop, site, oracle, t_cap, free_from,
    max_expansions, scratch,
):  # fmt: skip
    """The A* loop of ``reservations._astar``: (the path's length in ``scratch.path``, 0
    when none, or a ``ROOM_*`` code; the states expanded). A state ``(p, t)`` is the key
    ``p * span + t - t_start``; its parent's key is kept in an open-addressing table
    (``scratch.keys``, ``scratch.parents``; -1: the start), grown before it is half full.

    The states pop in the order of the specification's heap of ``(f, h, t, p)``: with a
    consistent heuristic (breadth-first distances change by one a move at most) a pushed
    state's ``f`` is the popped one's plus 0, 1 or 2, so every open ``f`` lies in
    ``f_now .. f_now + 2``; one heap per ``f`` (rows ``f % 3``) orders its states by
    ``h * n + p``, since ``t = t_start + f - h`` is then fixed."""
    occ, status, _, reach, _, _, deltas = site
    n = stop.size
    dist, mark = oracle[:n], oracle[n : 2 * n]
    span = t_cap - t_start + 1
    table, size, mask = 0, _FIRST_TABLE, _FIRST_TABLE - 1
    keys, parents = scratch.keys[0, :size], scratch.parents[0, :size]
    keys[:] = _EMPTY
    i = _slot(keys, start * span, mask)
    keys[i], parents[i] = start * span, -1
    count, expansions, f_now = 1, 0, resume(oracle, *site, start)
    levels, sizes = scratch.levels, scratch.sizes  # the heap of f at row f % 3
    sizes[:] = 0
    _push(levels, sizes, f_now % 3, f_now * n + start)
    while sizes[0] or sizes[1] or sizes[2]:
        if sizes[f_now % 3] == 0:
            f_now += 1
            continue
        hp_p = _pop(levels, sizes, f_now % 3)
        hp, p = hp_p // n, hp_p % n
        t = t_start + f_now - hp
        expansions += 1
        if expansions > max_expansions:
            break
        if t >= t_cap:
            continue
        if 2 * (count + len(deltas) + 1) > size:  # room for this expansion's states
            if not _grow(scratch, table, size):
                return ROOM_TABLE, expansions
            table, size = 1 - table, 2 * size
            keys, parents = scratch.keys[table, :size], scratch.parents[table, :size]
            mask = size - 1
        t1 = t + 1
        if _held(rows, head, nxt, rel, p, t1, t1):
            continue  # someone enters these cells at t1: it had to leave before
        here = p * span + t - t_start
        i = _slot(keys, here + 1, mask)
        if p != goal and keys[i] == _EMPTY:  # standing in the goal pose is no arrival
            keys[i], parents[i] = here + 1, here
            count += 1
            if not _push(levels, sizes, (f_now + 1) % 3, hp * n + p):
                return ROOM_HEAP, expansions
        for d in deltas:
            q = p + d
            if q < 0 or q >= n or stop[q] or not fits_base(occ, status, reach, rel, q):
                continue
            hq = np.int64(dist[q]) if mark[q] == CLOSED else resume(oracle, *site, q)
            if hq < 0:
                continue
            key = q * span + t1 - t_start
            i = _slot(keys, key, mask)
            if keys[i] != _EMPTY or _held(rows, head, nxt, rel, q, t, t1):
                continue
            if q == goal and t1 < free_from:
                continue
            keys[i], parents[i] = key, here
            if q == goal:
                return _path(keys, parents, key, span, scratch.path), expansions
            count += 1
            f = t1 - t_start + hq
            if f - f_now > 2 or f < f_now:
                raise ValueError("the A* heuristic must be consistent (breadth-first moves)")
            if not _push(levels, sizes, f % 3, hq * n + q):
                return ROOM_HEAP, expansions
    return 0, expansions


@_kernel
def _path(keys, parents, found, span, path):
    """The positions from the start to the state ``found``, following the parents, into
    ``path``: their count, or ``ROOM_PATH`` when ``path`` is too short."""
    mask = keys.size - 1
    length = (found % span) + 1  # one position per time step from t_start
    if length > path.size:
        return ROOM_PATH
    node = found
    for k in range(length - 1, -1, -1):
        path[k] = node // span
        node = parents[_slot(keys, node, mask)]
    return length
