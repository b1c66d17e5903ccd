"""Distances to a search's goal, found only where the search asks: a resumable reverse search.

The space-time A* (``multicrane.tasks.search_kernels``) orders its states by the number of
moves from a position to the goal around walls and placed components (arrived or assembled),
for the component's shape and, with reach limits, inside the crane's reach: the shape's
*field*. A breadth-first pass over the whole field gives every such distance, but a search
asks for a few hundred positions of a grid of thousands (hall-4c: about 200 of 7,280; the
large test halls: 194,526 positions). An *oracle* answers where asked:

- a reverse A* from the goal toward the search's start, its heuristic the Manhattan distance
  to the start (consistent for the six unit moves: an open position's f never falls, and a
  move adds 0 or 2 to it, so two FIFO buckets hold the open list);
- resumed until the asked position is closed: a closed position's distance is exact, the
  number the breadth-first pass gives (the resumable reverse A* of Silver's cooperative
  pathfinding, 2005); a position outside the field, or not closed when the open list runs
  dry, is -1.

An oracle is one int32 array, ``4 n + 8`` long for ``n`` positions: the distances found,
each position's mark, the two buckets, the queue (head and tail of bucket f, tail of bucket
f + 2, f, its row) and the start's coordinates. ``lazy_distances`` starts one for a shape and a
goal; ``known_distances`` wraps given distances (every position closed), so the tests can hand
the A* any field. The site comes with each question: ``occ`` (``FREE``, ``WALL`` or component
+ 1 per cell), the statuses, the static grid, ``reach`` (a bool per position, all True for no
limit), the shape, each position's coordinates (x, y, z of position p at 3p .. 3p + 2) and the
moves. A caller reads ``oracle[q]`` when ``oracle[n + q] == CLOSED`` and calls ``resume``
otherwise (the A* asks thousands of times, a call costs more than the read). ``fits_base`` is
the A*'s other question: does the shape fit the base (walls, obstacles, yard, placed
components) at a position.

numba checks a cached kernel against its own file only; the kernels that inline these are
recompiled after an edit here because ``multicrane.tasks`` drops the folder's caches when a
kernel source is newer (``multicrane.core.kernel_cache``).
"""

from __future__ import annotations

import numba
import numpy as np

from multicrane.core.codes import Status
from multicrane.sim.site import FREE, WALL

_IN_TRANSIT, _ARRIVED = int(Status.IN_TRANSIT), int(Status.ARRIVED)
UNSEEN, OPEN, CLOSED, OUTSIDE = 0, 1, 2, 3  # a position's mark in the reverse search


@numba.njit(cache=True)
def known_distances(h):
    """An oracle whose every answer is given: ``h``, a distance per position (-1: none)."""
    n = h.size
    oracle = np.zeros(4 * n + 8, dtype=np.int32)
    oracle[:n] = h
    oracle[n : 2 * n] = CLOSED
    return oracle


@numba.njit(cache=True)
def lazy_distances(occ, status, static, reach, rel, coords, start, goal):
    """An oracle for shape ``rel`` and ``goal``, aimed at ``start`` (module doc)."""
    oracle = np.empty(4 * occ.size + 8, dtype=np.int32)
    start_oracle(oracle, occ, status, static, reach, rel, coords, start, goal)
    return oracle


@numba.njit(cache=True, _nrt=False)
def start_oracle(oracle, occ, status, static, reach, rel, coords, start, goal):
    """``lazy_distances`` into ``oracle`` (``4 n + 8`` int32s, any content), allocating
    nothing."""
    n = occ.size
    oracle[n : 2 * n] = UNSEEN
    queue = oracle[4 * n :]
    queue[:5] = 0
    for i in range(3):
        queue[5 + i] = coords[3 * start + i]
    if in_field(occ, status, static, reach, rel, goal):
        oracle[goal] = 0
        oracle[n + goal] = OPEN
        oracle[2 * n] = goal  # bucket row 0 holds the goal
        queue[1] = 1
        queue[3] = _manhattan(coords, queue, goal)
    else:
        oracle[n + goal] = OUTSIDE


@numba.njit(cache=True, inline="always")
def _manhattan(coords, queue, p):
    """The Manhattan distance from position ``p`` to the start (``queue[5:8]``)."""
    return abs(coords[3 * p] - queue[5]) + abs(coords[3 * p + 1] - queue[6]) + abs(
        coords[3 * p + 2] - queue[7])  # fmt: skip


@numba.njit(cache=True, inline="always")
def in_field(occ, status, static, reach, rel, p):
    """The shape at ``p`` lies clear of walls and placed components, and in the reach."""
    n = occ.size
    for r in rel:
        c = p + r
        if c < 0 or c >= n or static[c] == WALL:
            return False
        v = occ[c]
        if v > 0 and status[v - 1] >= _ARRIVED:
            return False
    return reach[p]  # (tested last, and no test of its size: numba's code is slower so)


@numba.njit(cache=True, inline="always")
def fits_base(occ, status, reach, rel, p):
    """The shape at ``p`` lies in the reach (``reach``: a bool per position, all True for no
    limit) and each of its cells is free or held by a component in transit."""
    n = occ.size
    for r in rel:
        c = p + r
        if c < 0 or c >= n:
            return False
        v = occ[c]
        if v != FREE and not (v > 0 and status[v - 1] == _IN_TRANSIT):
            return False
    return reach[p]


@numba.njit(cache=True)
def resume(oracle, occ, status, static, reach, rel, coords, deltas, q):
    """The distance of position ``q``, going on with the reverse search until it closes
    ``q`` (or runs dry: -1)."""
    n = occ.size
    dist, mark, queue = oracle[:n], oracle[n : 2 * n], oracle[4 * n :]
    m = mark[q]
    if m == CLOSED:
        return np.int64(dist[q])
    if m == OUTSIDE or (m == UNSEEN and not in_field(occ, status, static, reach, rel, q)):
        mark[q] = OUTSIDE
        return np.int64(-1)
    buckets = oracle[2 * n : 4 * n].reshape(2, n)
    head, tail, after, f, row = queue[0], queue[1], queue[2], queue[3], queue[4]
    found = np.int64(-1)
    while True:
        if head == tail:
            if after == 0:
                break
            row = 1 - row
            head, tail, after, f = 0, after, 0, f + 2
            continue
        p = buckets[row, head]
        head += 1
        if mark[p] == CLOSED:
            continue  # an older entry: closed through a shorter way since
        mark[p] = CLOSED
        step = dist[p] + 1
        for d in deltas:
            r = p + d
            if r < 0 or r >= n:
                continue
            m = mark[r]
            if m >= CLOSED or (m == OPEN and dist[r] <= step):  # closed or outside, or no gain
                continue
            if m == UNSEEN and not in_field(occ, status, static, reach, rel, r):
                mark[r] = OUTSIDE
                continue
            mark[r] = OPEN
            dist[r] = step
            if step + _manhattan(coords, queue, r) == f:
                buckets[row, tail] = r
                tail += 1
            else:
                buckets[1 - row, after] = r
                after += 1
        if p == q:
            found = np.int64(dist[q])
            break
    queue[0], queue[1], queue[2], queue[3], queue[4] = head, tail, after, f, row
    return found
