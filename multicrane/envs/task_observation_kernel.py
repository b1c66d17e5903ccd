"""The task observation's ``components`` table, compiled: one pass over the components.

``component_rows_kernel`` fills the table that ``multicrane.envs.task_observation`` describes
(its columns, in ``COMPONENT_FEATURES`` order, then one reach column per crane and, with site
events, ``delivered``) from plain arrays, with the same float arithmetic as the numpy
expressions it replaced (float64 path lengths divided by ``D``, stored as float32), so the
observations are bit-identical; ``tests/envs/test_task_observation.py`` checks it against
them.
"""

from __future__ import annotations

import numba
import numpy as np

_INITIAL = 0


@numba.njit(cache=True, _nrt=False)
def component_rows_kernel(
    comp, status, first, last, coords, beam, targets, target_ready, claimable, taken,
    free_target, task_comp, task_target, pair_len, reach, D, events, delivered, best,
):  # fmt: skip
    """Fill ``comp`` (C x (21 + N + events), float32, zeroed). ``first``/``last``: each
    component's first and last cell (its pick-up pose's when initial; -1: none);
    ``claimable``/``taken``: component indices; ``pair_len``: each task's shortest static
    path (inf: none); ``best``: scratch, C float64s (nothing here allocates)."""
    C, N = comp.shape[0], reach.shape[1]
    best[:] = np.inf
    for p in range(task_comp.size):
        if free_target[task_target[p]] and pair_len[p] < best[task_comp[p]]:
            best[task_comp[p]] = pair_len[p]
    for c in range(C):
        comp[c, 0] = beam[c]
        comp[c, 1 + status[c]] = 1.0
        if first[c] >= 0:
            for i in range(3):
                comp[c, 5 + i] = coords[first[c], i]
                comp[c, 8 + i] = coords[last[c], i]
        for i in range(6):
            comp[c, 11 + i] = targets[c, i]
        comp[c, 17] = target_ready[c]
        if status[c] != _INITIAL:
            comp[c, 20] = 0.0
        elif np.isfinite(best[c]):
            comp[c, 20] = min(best[c] / D, 1.0)
        else:
            comp[c, 20] = 1.0
        for k in range(N):
            comp[c, 21 + k] = reach[c, k]
    for c in claimable:
        comp[c, 18] = 1.0
    for c in taken:
        comp[c, 19] = 1.0
    if events:
        last_column = comp.shape[1] - 1
        for c in range(C):
            if not delivered[c]:
                comp[c, :11] = 0.0  # only "not delivered" (and its own target) is known
                comp[c, 17:] = 0.0
            comp[c, last_column] = delivered[c]
