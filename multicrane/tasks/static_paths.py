"""Shortest static path lengths of the tasks: through walls and obstacles only, per crane zone.

A task's static length is the fewest moves of its component, rigid, from its pick-up pose to
its target's pose through the site without any other component (the same for every crane
without reach zones; inside the crane's zone with them). The task book ranks and masks tasks
with it and the task observation shows it; the breadth-first distances behind it
(``breadth_first_kernel``, compiled) are cached for the life of the site, per (shape, goal
pose, zone).
"""

from __future__ import annotations

import numba
import numpy as np

from multicrane.sim.shortest_paths import UNREACHABLE, fits_everywhere
from multicrane.sim.simulator import FREE, Simulator
from multicrane.tasks.goal_poses import GoalPoses


class StaticPaths:
    """Shortest path lengths through the static site (walls and obstacles only), per
    (component shape, goal pose, crane zone); cached for the life of the site."""

    def __init__(self, sim: Simulator, goals: GoalPoses | None = None):
        self.sim = sim
        self.free = sim.site.static == FREE
        self._fit: dict[tuple, np.ndarray] = {}
        self._dist: dict[tuple, np.ndarray] = {}  # int16 where every distance fits
        self._goal = GoalPoses(sim.site) if goals is None else goals  # the carrier's, shared
        self._deltas = np.asarray(sim.site.move_delta, dtype=np.int64)

    def length(self, pickup: list[int], target: int, zone: int) -> int:
        """Moves from the pick-up pose to the target's pose (``UNREACHABLE``: none)."""
        return self.lengths(pickup, [target], zone)[0]

    def lengths(self, pickup: list[int], targets, zone: int) -> list[int]:
        """``length`` to each of ``targets`` from one pick-up pose."""
        if not pickup:
            return [UNREACHABLE] * len(targets)
        start = pickup[0]
        rel = tuple(j - start for j in pickup)
        out = []
        for target in targets:
            dist = self._distances(rel, target, zone)
            out.append(UNREACHABLE if dist is None else int(dist[start]))
        return out

    def _distances(self, rel: tuple[int, ...], target: int, zone: int) -> np.ndarray | None:
        """Moves from every position of the shape to the target's pose (cached); None when
        no pose of the shape covers the target's cells."""
        goal = self._goal[rel, target]
        if goal is None:
            return None
        key = (rel, goal, zone)
        dist = self._dist.get(key)
        if dist is None:
            fit = self._fit.get((rel, zone))
            if fit is None:
                fit = fits_everywhere(self.free, rel)
                if zone >= 0:
                    fit &= fits_everywhere(self.sim.site.reach[zone], rel)
                self._fit[(rel, zone)] = fit
            dist = compact(breadth_first_kernel(fit, goal, self._deltas))
            self._dist[key] = dist
        return dist


def compact(dist: np.ndarray) -> np.ndarray:
    """Distances (int32, -1: none) as int16 when every one fits: a site keeps many fields."""
    if dist.size and dist.max() <= np.iinfo(np.int16).max:
        return dist.astype(np.int16)
    return dist


@numba.njit(cache=True)
def breadth_first_kernel(ok, goal, deltas):
    """Moves from every position to ``goal`` over positions in ``ok`` (-1 where none): the
    distances of ``multicrane.sim.grid_search.breadth_first(ok, [goal], deltas)``, for the
    grid's six moves (``deltas``; ValueError otherwise)."""
    if deltas.size != 6:
        raise ValueError("breadth_first_kernel takes the six moves of the grid")
    return _breadth_first_six(ok, goal, deltas)


@numba.njit(cache=True)
def _breadth_first_six(ok, goal, deltas):
    """``breadth_first_kernel`` with its loop over the six moves unrolled."""
    n = ok.size
    dist = np.full(n, -1, dtype=np.int32)
    if not ok[goal]:
        return dist
    d0, d1, d2, d3, d4, d5 = deltas[0], deltas[1], deltas[2], deltas[3], deltas[4], deltas[5]
    open_ = ok.copy()  # in ``ok`` and not reached yet
    queue = np.empty(n, dtype=np.int32)  # positions (a grid has fewer than 2**31)
    queue[0] = goal
    dist[goal] = 0
    open_[goal] = False
    head, tail = 0, 1
    while head < tail:
        p = queue[head]
        head += 1
        step = dist[p] + 1
        for d in (d0, d1, d2, d3, d4, d5):
            q = p + d
            if 0 <= q < n and open_[q]:
                open_[q] = False
                dist[q] = step
                queue[tail] = q
                tail += 1
    return dist
