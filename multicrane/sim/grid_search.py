"""Whole-array search on the padded grid: where a rigid shape fits, and breadth-first distances.

A position is the linear index of a shape's first cell in ``multicrane.sim.site``'s padded grid;
a move adds one constant to it. These functions work on whole numpy arrays (one shifted copy
per offset or per move and search depth) and know nothing of the episode state, so the loader's
reach check and the planners' path searches share them.
"""

from __future__ import annotations

import numpy as np

UNREACHABLE = -1


def fits_everywhere(free: np.ndarray, offsets) -> np.ndarray:
    """Boolean per position p: every cell ``p + o`` (o in ``offsets``) is free."""
    n = free.size
    ok = np.ones(n, dtype=bool)
    for o in offsets:
        if o > 0:
            ok[: n - o] &= free[o:]
            ok[n - o :] = False  # p + o would leave the array
        elif o == 0:
            ok &= free
        else:
            ok[-o:] &= free[: n + o]
            ok[:-o] = False
    return ok


def breadth_first(
    ok: np.ndarray, starts: list[int], deltas, through: np.ndarray | None = None
) -> np.ndarray:
    """Moves from the nearest start to every position, over positions in ``ok`` (the moves
    are symmetric, so this is also the distance *to* the nearest start). Positions outside
    ``through`` are reached but not expanded. ``UNREACHABLE`` where none.

    The frontier is kept as an index array, so each depth costs the size of its frontier,
    not of the grid (a position p's neighbours are ``p + d``, those inside the array); the
    moves are taken one at a time, each closing what it finds, so no position is found twice.
    Equal to the whole-array version it replaced (tests/sim/test_incremental.py)."""
    n = ok.size
    dist = np.full(n, UNREACHABLE, dtype=np.int32)
    first = np.array(sorted({int(s) for s in starts if ok[s]}), dtype=np.intp)
    dist[first] = 0
    steps = [int(d) for d in deltas]
    # Padding: a neighbour index outside 0..n-1 reads a False of ``open_`` instead.
    pad = max((abs(d) for d in steps), default=0)
    open_ = np.zeros(n + 2 * pad, dtype=bool)  # not yet reached, and in ``ok``
    open_[pad : pad + n] = ok
    open_[first + pad] = False
    frontier = (first if through is None else first[through[first]]) + pad
    depth = 0
    while frontier.size:
        depth += 1
        found = []
        for d in steps:
            nxt = frontier + d
            nxt = nxt[open_[nxt]]
            open_[nxt] = False
            found.append(nxt)
        frontier = np.concatenate(found)
        dist[frontier - pad] = depth
        if through is not None:
            frontier = frontier[through[frontier - pad]]
    return dist
