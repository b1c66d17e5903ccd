"""Goal poses: where a component's shape covers a target, and the distances to them.

A component's *position* is its first cell's linear index and its *shape* (``rel``) the
offsets of its cells from that one (``multicrane.tasks.reservations``). ``goal_position`` is
the position at which a shape covers a target's cells exactly (None: no pose of that shape
does); ``GoalPoses`` keeps them per (shape, target) for one site, and gives every
(component, target) pair's Manhattan distance from the pick-up pose to the goal pose
(``pair_distances``, the prioritized rule's ranking key).
"""

from __future__ import annotations

import numpy as np


def goal_position(rel: tuple[int, ...], target_cells: list[int]) -> int | None:
    """The position at which a component of this shape covers the target's cells exactly."""
    tc = sorted(target_cells)
    srel = sorted(rel)
    start = tc[0] - srel[0]
    if [start + r for r in srel] == tc:
        return start
    return None


class GoalPoses(dict):
    """``goal_position`` per (shape, target) of one site, each computed once:
    ``poses[rel, target]``."""

    def __init__(self, site):
        super().__init__()
        self.site = site
        self._rows: dict[tuple[int, ...], np.ndarray] = {}  # goal positions per shape
        self._table: np.ndarray | None = None  # site.compatible as a table

    def __missing__(self, key: tuple[tuple[int, ...], int]) -> int | None:
        rel, target = key
        goal = self[key] = goal_position(rel, self.site.target_cells[target])
        return goal

    def pair_distances(self, pickup: list[list[int]]) -> np.ndarray:
        """(components, targets) int64: the Manhattan distance from each component's pick-up
        pose (``pickup``, the state's) to its pose on each compatible target, -1 where no pose
        of its shape covers the target (or the target is not compatible)."""
        site = self.site
        dist = np.full((site.n_components, len(site.target_cells)), -1, dtype=np.int64)
        by_shape: dict[tuple[int, ...], list[int]] = {}
        for comp, pick in enumerate(pickup):
            if pick:
                by_shape.setdefault(tuple(j - pick[0] for j in pick), []).append(comp)
        for rel, comps in by_shape.items():
            goals = self._goal_row(rel)
            ok = self._compatible()[comps] & (goals >= 0)
            starts = site.grid_coords([pickup[c][0] for c in comps])
            ends = site.grid_coords(np.maximum(goals, 0))
            d = np.abs(starts[:, None, :] - ends[None]).sum(axis=2)
            dist[comps] = np.where(ok, d, -1)
        return dist

    def _goal_row(self, rel: tuple[int, ...]) -> np.ndarray:
        """(targets,) int64: the shape's goal position on each target, -1 where none."""
        row = self._rows.get(rel)
        if row is None:
            goals = (self[rel, t] for t in range(len(self.site.target_cells)))
            row = np.array([-1 if g is None else g for g in goals], dtype=np.int64)
            self._rows[rel] = row
        return row

    def _compatible(self) -> np.ndarray:
        """(components, targets) bool: ``site.compatible`` as a table."""
        if self._table is None:
            site = self.site
            self._table = np.zeros((site.n_components, len(site.target_cells)), dtype=bool)
            for comp, targets in enumerate(site.compatible):
                self._table[comp, list(targets)] = True
        return self._table


def manhattan(a: tuple[int, int, int], b: tuple[int, int, int]) -> int:
    return abs(a[0] - b[0]) + abs(a[1] - b[1]) + abs(a[2] - b[2])
