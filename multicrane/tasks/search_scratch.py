"""The working space of a space-time search: arrays a kernel that must not allocate gets given.

``multicrane.tasks.search_kernels`` runs the A* in a ``SearchScratch``: the rows' cell lists,
the layers of its count below the goal's free time, the state table (two buffers: it grows
from one into the other), the three heaps and the path found. A search that needs more room
than it has returns a ``ROOM_*`` code instead of a path length, and its caller grows that
array (``grown_scratch``) and asks again: a search is a function of its inputs, so the answer
is the one it would have given in ample space. The one-site carrier keeps one scratch per grid
size, grown as its searches need (``reservation_arrays.compiled_search``); the task vector env
gives room enough for any search up front (``multicrane.vector.task_state``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class SearchScratch(NamedTuple):
    """The working arrays of one search, reused from search to search (a kernel that must not
    allocate gets them from its caller): the rows' cell lists, the layers of
    ``_states_below``, the state table (two buffers: it grows from one into the other), the
    three heaps and the path found."""

    head: np.ndarray  # (n,) int32: a cell's first row
    nxt: np.ndarray  # (rows,) int32: each row's next
    layer_of: np.ndarray  # (n,) int32
    layer: np.ndarray  # (n,) int32
    after: np.ndarray  # (n,) int32
    keys: np.ndarray  # (2, K) int64: K a power of two
    parents: np.ndarray  # (2, K) int64
    levels: np.ndarray  # (3, H) int64
    sizes: np.ndarray  # (3,) int64
    path: np.ndarray  # (L,) int64


# A search that needs more room than its scratch has returns one of these instead of a path
# length; the caller grows that array and asks again (a search is a function of its inputs).
ROOM_ROWS, ROOM_TABLE, ROOM_HEAP, ROOM_PATH = -2, -3, -4, -5
_FIRST_TABLE = 1024  # the state table's size at a search's start


def search_scratch(n: int, rows: int = 256, table: int = 1 << 14, heap: int = 4096,
                   path: int = 256) -> SearchScratch:  # fmt: skip
    """Scratch space for searches over ``n`` positions (``table`` rounded up to a power of
    two, at least ``_FIRST_TABLE``)."""
    K = max(_FIRST_TABLE, 1 << max(int(table) - 1, 1).bit_length())
    return SearchScratch(
        head=np.empty(n, dtype=np.int32),
        nxt=np.empty(max(rows, 1), dtype=np.int32),
        layer_of=np.empty(n, dtype=np.int32),
        layer=np.empty(n, dtype=np.int32),
        after=np.empty(n, dtype=np.int32),
        keys=np.empty((2, K), dtype=np.int64),
        parents=np.empty((2, K), dtype=np.int64),
        levels=np.empty((3, max(heap, 1)), dtype=np.int64),
        sizes=np.zeros(3, dtype=np.int64),
        path=np.empty(max(path, 1), dtype=np.int64),
    )


def grown_scratch(scratch: SearchScratch, room: int, n_rows: int) -> SearchScratch:
    """``scratch`` with the array that ``room`` (a ``ROOM_*`` code) names grown: the rows'
    list to ``n_rows`` at least, the others to twice their size."""
    if room == ROOM_ROWS:
        return scratch._replace(nxt=np.empty(max(n_rows, 2 * scratch.nxt.size), np.int32))
    if room == ROOM_TABLE:
        K = 2 * scratch.keys.shape[1]
        return scratch._replace(keys=np.empty((2, K), np.int64), parents=np.empty((2, K), np.int64))
    if room == ROOM_HEAP:
        return scratch._replace(levels=np.empty((3, 2 * scratch.levels.shape[1]), np.int64))
    if room == ROOM_PATH:
        return scratch._replace(path=np.empty(2 * scratch.path.size, np.int64))
    raise ValueError(f"not a room code: {room}")
