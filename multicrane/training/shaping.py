"""Potential-based reward shaping for multi-crane training (Ng, Harada & Russell, 1999).

The team reward pays only on assembly, and random cranes hardly ever carry a component to
its target before the over-limit cost (-2 per step past 15 moves) sets in; PPO then learns
to wait forever (-1 per step, the best return random exploration ever shows it). Adding
``F = w * (gamma * phi(s') - phi(s))`` with

    phi(s) = - sum over unassembled components of the Manhattan distance (cells) from the
             component's position (its pick-up pose while in the yard) to the nearest pose
             where it would fill a free compatible target,

rewards every move towards a target and leaves the optimal policies of the discounted
problem unchanged (the shaping terms telescope). ``phi`` is 0 at the end of an episode.
Claiming does not change ``phi`` (a claimed component starts at its pick-up pose). The
environment's own reward, returns and statistics are untouched: only the reward the
learner sees changes.
"""

from __future__ import annotations

from multicrane.paths import current_cells, goal_positions
from multicrane.simulator import NOBODY, Simulator
from multicrane.types import Status

_ASSEMBLED = int(Status.ASSEMBLED)
_ARRIVED = int(Status.ARRIVED)


class DistancePotential:
    """``phi`` of the module doc for one simulator; call ``reset()`` after the env's reset."""

    def __init__(self, sim: Simulator):
        self.sim = sim
        self._goals: dict[tuple[int, int], list[tuple[int, int, int]]] = {}

    def reset(self) -> None:
        self._goals.clear()  # the layout (pick-up poses) may change between episodes

    def _goal_cells(self, comp: int, target: int) -> list[tuple[int, int, int]]:
        key = (comp, target)
        if key not in self._goals:
            self._goals[key] = [
                self.sim.site.cell(g) for g in goal_positions(self.sim, comp, [target])
            ]
        return self._goals[key]

    def __call__(self) -> float:
        sim = self.sim
        total = 0
        for comp in range(sim.site.n_components):
            status = int(sim.state.status[comp])
            if status in (_ASSEMBLED, _ARRIVED) or sim.state.prebuilt[comp]:
                continue
            x, y, z = sim.site.cell(current_cells(sim, comp)[0])
            best = None
            for t in sim.site.compatible[comp]:
                if sim.state.filled_by[t] != NOBODY:
                    continue
                for gx, gy, gz in self._goal_cells(comp, t):
                    d = abs(gx - x) + abs(gy - y) + abs(gz - z)
                    if best is None or d < best:
                        best = d
            total += best or 0
        return -float(total)
