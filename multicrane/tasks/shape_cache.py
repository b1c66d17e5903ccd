"""What the carrier's searches read besides the reservations: base, reach, distance oracles.

A space-time search (``multicrane.tasks.search_kernels``) asks of a position whether the
component's shape fits the base there and how far it is from the goal
(``multicrane.tasks.distance_oracle``). ``ShapeCache`` gives it the inputs: the site's cells and
statuses now, where the shape lies in the crane's reach (a bool per position, kept per shape
and crane), the grid coordinates, and an oracle per (shape, goal, crane, start). An oracle
holds the distances its reverse search found so far; they depend on the site, the shape, the
reach and the placed components, which the filled targets fix (a component fills its target
from its arrival on). So the oracles are kept under the filled targets (the last
``capacity``), for the episode's copies and later episodes alike: a search asked again (a held
task retried each step, a rollout) goes on where the last one stopped.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from multicrane.sim.shortest_paths import fits_everywhere
from multicrane.sim.simulator import Simulator
from multicrane.sim.site import Site
from multicrane.tasks.distance_oracle import fits_base, lazy_distances

_ORACLE_BYTES = 32 << 20  # the oracles kept hold about this much at most (16 a position)


class ShapeCache:
    """One site's search inputs: base, reach and distance oracles (module doc)."""

    def __init__(self, site: Site):
        self.site = site
        self.coords = site.grid_coords().astype(np.int32).ravel()  # x, y, z of p at 3p
        self.deltas = np.asarray(site.move_delta, dtype=np.int64)
        self._reach: dict[tuple, np.ndarray] = {}
        self._everywhere = np.ones(site.size, dtype=np.bool_)  # the reach without limits
        self.capacity = max(8, min(64, _ORACLE_BYTES // (16 * site.size)))
        self._oracles: OrderedDict[tuple, np.ndarray] = OrderedDict()

    def reach(self, rel: tuple[int, ...], zone: int) -> np.ndarray:
        """Positions where a shape lies wholly in crane ``zone``'s reach (``Site.reach``);
        every position for ``zone < 0`` (no limit)."""
        if zone < 0:
            return self._everywhere
        fit = self._reach.get((rel, zone))
        if fit is None:
            fit = self._reach[rel, zone] = fits_everywhere(self.site.reach[zone], rel)
        return fit

    def site_inputs(self, sim: Simulator, rel: tuple[int, ...], zone: int) -> tuple:
        """``(occ, status, static, reach, coords, deltas)``: what a search reads of the site
        now (``reservation_arrays.compiled_search``)."""
        st = sim.state
        return st.occ, st.status, self.site.static, self.reach(rel, zone), self.coords, self.deltas

    def fits(self, sim: Simulator, rel: tuple[int, ...], zone: int, p: int) -> bool:
        """The shape at ``p`` fits the base now (``distance_oracle.fits_base``), in crane
        ``zone``'s reach."""
        st = sim.state
        rel_a = np.asarray(rel, dtype=np.int64)
        return bool(fits_base(st.occ, st.status, self.reach(rel, zone), rel_a, p))

    def oracle(
        self, sim: Simulator, rel: tuple[int, ...], goal: int, zone: int, start: int
    ) -> np.ndarray:
        """The distance oracle of a shape's moves to ``goal`` in crane ``zone``'s reach,
        aimed at ``start``, for the components placed now (kept: module doc)."""
        st = sim.state
        key = (st.filled.tobytes(), rel, goal, zone, start)
        kept = self._oracles
        oracle = kept.get(key)
        if oracle is not None:
            kept.move_to_end(key)
            return oracle
        occ, status, static, reach, coords, _ = self.site_inputs(sim, rel, zone)
        rel_a = np.asarray(rel, dtype=np.int64)
        oracle = lazy_distances(occ, status, static, reach, rel_a, coords, start, goal)
        kept[key] = oracle
        if len(kept) > self.capacity:
            kept.popitem(last=False)
        return oracle
