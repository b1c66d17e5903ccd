"""Shortest static path lengths of the tasks: through walls and obstacles only, per crane zone.

A task's static length is the fewest moves of its component, rigid, from its pick-up pose to
its target's pose through the site without any other component (the same for every crane
without reach zones; inside the crane's zone with them). The task book ranks and masks tasks
with it and the task observation shows it; the breadth-first distances behind it are cached
for the life of the site, per (shape, goal pose, zone).
"""

from __future__ import annotations

import numpy as np

from multicrane.sim.shortest_paths import UNREACHABLE, breadth_first, fits_everywhere
from multicrane.sim.simulator import FREE, Simulator
from multicrane.tasks.reservations import goal_position


class StaticPaths:
    """Shortest path lengths through the static site (walls and obstacles only), per
    (component shape, goal pose, crane zone); cached for the life of the site."""

    def __init__(self, sim: Simulator):
        self.sim = sim
        self.free = sim.site.static == FREE
        self._fit: dict[tuple, np.ndarray] = {}
        self._dist: dict[tuple, np.ndarray] = {}
        self._goal: dict[tuple, int | None] = {}  # (shape, target) -> the goal pose

    def length(self, pickup: list[int], target: int, zone: int) -> int:
        """Moves from the pick-up pose to the target's pose (``UNREACHABLE``: none)."""
        if not pickup:
            return UNREACHABLE
        site = self.sim.site
        rel = tuple(j - pickup[0] for j in pickup)
        if (rel, target) not in self._goal:
            self._goal[(rel, target)] = goal_position(rel, site.target_cells[target])
        goal = self._goal[(rel, target)]
        if goal is None:
            return UNREACHABLE
        key = (rel, goal, zone)
        dist = self._dist.get(key)
        if dist is None:
            fit = self._fit.get((rel, zone))
            if fit is None:
                fit = fits_everywhere(self.free, rel)
                if zone >= 0:
                    fit &= fits_everywhere(site.reach[zone], rel)
                self._fit[(rel, zone)] = fit
            dist = breadth_first(fit, [goal], site.move_delta)
            self._dist[key] = dist
        return int(dist[pickup[0]])
