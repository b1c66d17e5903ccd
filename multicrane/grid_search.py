"""Whole-array search on the padded grid: where a rigid shape fits, and breadth-first distances.

A position is the linear index of a shape's first cell in ``multicrane.site``'s padded grid;
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
    ``through`` are reached but not expanded. ``UNREACHABLE`` where none."""
    n = ok.size
    dist = np.full(n, UNREACHABLE, dtype=np.int32)
    frontier = np.zeros(n, dtype=bool)
    frontier[[s for s in starts if ok[s]]] = True
    dist[frontier] = 0
    seen = frontier.copy()
    if through is not None:
        frontier &= through
    depth = 0
    while frontier.any():
        depth += 1
        nxt = np.zeros(n, dtype=bool)
        for d in deltas:
            if d > 0:
                nxt[d:] |= frontier[: n - d]
            else:
                nxt[: n + d] |= frontier[-d:]
        nxt &= ok & ~seen
        dist[nxt] = depth
        seen |= nxt
        frontier = nxt if through is None else nxt & through
    return dist
