"""Compiled kernels of the carrier's searches: space-time A*, breadth-first distances, table scans.

The reservations here are flat rows ``(cell, from, to, component)`` (``ReservationArrays``,
``multicrane.tasks.reservation_arrays``), positions and shapes are linear indices of the padded
grid, exactly as in ``multicrane.tasks.reservations``, whose Python ``space_time_search`` is the
specification: ``space_time_kernel`` follows it step for step (the same heap order, so the
same states expanded in the same order, the same path and the same count of expansions;
``tests/tasks/test_search_kernels.py`` compares them). Plain arrays in, plain arrays out; numba
``njit(cache=True)``, so a second process loads the machine code.
"""

from __future__ import annotations

import heapq

import numba
import numpy as np
from numba import types
from numba.typed import Dict

CELL, FROM, TO, OWNER = range(4)  # the columns of a reservation row


@numba.njit(cache=True)
def breadth_first_kernel(ok, goal, deltas):
    """Moves from every position to ``goal`` over positions in ``ok`` (-1 where none): the
    distances of ``multicrane.sim.grid_search.breadth_first(ok, [goal], deltas)``."""
    n = ok.size
    dist = np.full(n, -1, dtype=np.int32)
    if not ok[goal]:
        return dist
    queue = np.empty(n, dtype=np.int64)
    queue[0] = goal
    dist[goal] = 0
    head, tail = 0, 1
    while head < tail:
        p = queue[head]
        head += 1
        for d in deltas:
            q = p + d
            if 0 <= q < n and ok[q] and dist[q] < 0:
                dist[q] = dist[p] + 1
                queue[tail] = q
                tail += 1
    return dist


@numba.njit(cache=True)
def conflict_kernel(rows, n_rows, cells, lo, hi, me):
    """Another owner than ``me`` holds one of ``cells`` at some time in ``lo..hi``."""
    for i in range(n_rows):
        if rows[i, OWNER] != me and rows[i, FROM] <= hi and rows[i, TO] >= lo:
            c = rows[i, CELL]
            for j in cells:
                if c == j:
                    return True
    return False


@numba.njit(cache=True)
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


@numba.njit(cache=True)
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


@numba.njit(cache=True)
def _cell_lists(rows, n_rows, comp, t_start, n_cells):
    """Per cell, a linked list of the rows that can conflict with ``comp``'s search: other
    owners, holding until ``t_start`` or later (every query asks about ``t_start`` on)."""
    head = np.full(n_cells, -1, dtype=np.int64)
    nxt = np.empty(max(n_rows, 1), dtype=np.int64)
    for i in range(n_rows):
        c = rows[i, CELL]
        if rows[i, OWNER] != comp and rows[i, TO] >= t_start and 0 <= c < n_cells:
            nxt[i] = head[c]
            head[c] = i
    return head, nxt


@numba.njit(cache=True)
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


@numba.njit(cache=True)
def space_time_kernel(
    rows, n_rows, comp, rel, start, t_start, goal, stop, ok, h, deltas, slack,
    max_expansions, lifted_onto_goal_arrives, inf,
):  # fmt: skip
    """``reservations.space_time_search`` on flat reservation rows: (the path's positions,
    empty when none; the states expanded). ``stop``: a flag per position (the stop poses)."""
    h0 = np.int64(h[start])
    if h0 < 0 or not ok[goal]:
        return np.empty(0, dtype=np.int64), 0
    free_from = goal_free_from_kernel(rows, n_rows, comp, rel, goal, t_start, inf)
    if free_from < 0:
        return np.empty(0, dtype=np.int64), 0
    if start == goal and lifted_onto_goal_arrives:
        if t_start >= free_from:
            return np.full(1, start, dtype=np.int64), 0
        return np.empty(0, dtype=np.int64), 0
    t_cap = t_start + h0 + slack
    head, nxt = _cell_lists(rows, n_rows, comp, t_start, ok.size)
    return _astar(
        rows, head, nxt, rel, start, t_start, goal, stop, ok, h, deltas, t_cap, free_from,
        max_expansions,
    )  # fmt: skip


@numba.njit(cache=True)
def _astar(
    rows, head, nxt, rel, start, t_start, goal, stop, ok, h, deltas, t_cap, free_from,
    max_expansions,
):  # fmt: skip
    """The A* loop of ``reservations._astar``; a state ``(p, t)`` is the key
    ``p * span + t - t_start`` and its parent's key is kept in a typed dict (-1: the start)."""
    n = ok.size
    span = t_cap - t_start + 1
    parent = Dict.empty(key_type=types.int64, value_type=types.int64)
    parent[start * span] = -1
    h0 = np.int64(h[start])
    heap = [(h0, h0, t_start, start)]
    expansions = 0
    found = -1
    while heap:
        _, hp, t, p = heapq.heappop(heap)
        expansions += 1
        if expansions > max_expansions:
            break
        if t >= t_cap:
            continue
        t1 = t + 1
        if _held(rows, head, nxt, rel, p, t1, t1):
            continue  # someone enters these cells at t1: it had to leave before
        here = p * span + t - t_start
        key = here + 1
        if p != goal and key not in parent:  # standing in the goal pose is no arrival
            parent[key] = here
            heapq.heappush(heap, (t1 - t_start + hp, hp, t1, p))
        for d in deltas:
            q = p + d
            if q < 0 or q >= n or not ok[q] or stop[q]:
                continue
            hq = np.int64(h[q])
            if hq < 0:
                continue
            key = q * span + t1 - t_start
            if key in parent:
                continue
            if _held(rows, head, nxt, rel, q, t, t1):
                continue
            if q == goal:
                if t1 < free_from:
                    continue
                parent[key] = here
                found = key
                break
            parent[key] = here
            heapq.heappush(heap, (t1 - t_start + hq, hq, t1, q))
        if found >= 0:
            break
    if found < 0:
        return np.empty(0, dtype=np.int64), expansions
    length = (found % span) + 1  # one position per time step from t_start
    path = np.empty(length, dtype=np.int64)
    node = found
    for i in range(length - 1, -1, -1):
        path[i] = node // span
        node = parent[node]
    return path, expansions
