"""The carrier's per-shape caches: where a component shape fits the base, and distances to goals.

The *base* is what never moves during a search (walls, obstacles, yard components, arrived
and assembled ones; ``multicrane.tasks.reservations``); the distances, breadth-first around
walls and placed components, are the space-time search's heuristic. Both are numpy arrays
(one entry per position of the padded grid), as the compiled search takes them.
"""

from __future__ import annotations

import numpy as np

from multicrane.core.codes import Status
from multicrane.sim.shortest_paths import fits_everywhere
from multicrane.sim.simulator import FREE, WALL, Simulator
from multicrane.tasks.search_kernels import breadth_first_kernel

_IN_TRANSIT, _ARRIVED = int(Status.IN_TRANSIT), int(Status.ARRIVED)


class ShapeCache:
    """Per component shape: where it fits the base, and breadth-first distances to goals.

    The base fit is recomputed when some status changes, the distances when some component
    arrives or is assembled; both are cached per shape (and goal) until then.
    """

    def __init__(self, sim: Simulator):
        self.walls = sim.site.static == WALL
        self.deltas = np.asarray(sim.site.move_delta, dtype=np.int64)
        self._base_key: bytes | None = None
        self._base_free: np.ndarray | None = None
        self._fit: dict[tuple, np.ndarray] = {}
        self._h_cache: dict[tuple, np.ndarray] = {}
        self._h_key: bytes | None = None
        self._h_fit: dict[tuple, np.ndarray] = {}
        self._zone_fit: dict[tuple, np.ndarray] = {}

    def base_ok(self, sim: Simulator, rel: tuple[int, ...], zone: int = -1) -> np.ndarray:
        """Positions where a component of this shape fits the base (no component in transit)
        and, for ``zone >= 0``, lies wholly in that crane's reach (``Site.reach``)."""
        status = sim.state.status
        key = status.tobytes()
        if key != self._base_key:
            free = sim.state.occ == FREE
            free[_cells_of(sim, status == _IN_TRANSIT)] = True
            self._base_key, self._base_free, self._fit = key, free, {}
        ok = self._fit.get((rel, zone))
        if ok is None:
            ok = fits_everywhere(self._base_free, rel)
            if zone >= 0:
                ok &= self.zone_fit(sim, rel, zone)
            self._fit[(rel, zone)] = ok
        return ok

    def zone_fit(self, sim: Simulator, rel: tuple[int, ...], zone: int) -> np.ndarray:
        """Positions where a component of this shape lies wholly in crane ``zone``'s reach."""
        key = (rel, zone)
        fit = self._zone_fit.get(key)
        if fit is None:
            fit = fits_everywhere(sim.site.reach[zone], rel)
            self._zone_fit[key] = fit
        return fit

    def heuristic(
        self, sim: Simulator, rel: tuple[int, ...], goal: int, zone: int = -1
    ) -> np.ndarray:
        """Breadth-first moves to ``goal`` over walls and placed components, inside crane
        ``zone``'s reach when ``zone >= 0`` (-1: none)."""
        status = sim.state.status
        key = (status >= _ARRIVED).tobytes()
        if key != self._h_key:
            self._h_key, self._h_cache, self._h_fit = key, {}, {}
        h = self._h_cache.get((rel, goal, zone))
        if h is None:
            h = breadth_first_kernel(self._placed_fit(sim, rel, zone), goal, self.deltas)
            self._h_cache[(rel, goal, zone)] = h
        return h

    def _placed_fit(self, sim: Simulator, rel: tuple[int, ...], zone: int) -> np.ndarray:
        """Positions where the shape fits around walls and placed components (and in crane
        ``zone``'s reach when ``zone >= 0``); cached with the distances."""
        fit = self._h_fit.get((rel, zone))
        if fit is None:
            status = sim.state.status
            free = ~self.walls
            free[_cells_of(sim, status >= _ARRIVED)] = False
            fit = fits_everywhere(free, rel)
            if zone >= 0:
                fit &= self.zone_fit(sim, rel, zone)
            self._h_fit[(rel, zone)] = fit
        return fit


def _cells_of(sim: Simulator, chosen: np.ndarray) -> list[int]:
    """The cells of the components ``chosen`` (a bool per component) marks, in one list."""
    cells = sim.state.cells
    return [j for comp in np.flatnonzero(chosen).tolist() for j in cells[comp]]
