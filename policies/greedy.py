"""Greedy crane policy: nearest ready component, shortest path, wait when blocked.

Each idle crane claims the ready component whose pick-up pose is nearest to a target it can
fill; the held component follows a shortest path that treats every other component as a
fixed obstacle (``multicrane.sim.shortest_paths``); an arrived component is assembled at once. When
its path
is blocked (by a component that moved, or a crane that acted first this step) the crane waits
and replans; after ``patience`` blocked steps in a row it makes a random legal move, which
breaks the deadlocks two cranes can get into. It reads the simulator state (a planner, not a
learned policy) and acts through the environment's normal actions and masks.

With crane reach, the masks let a crane claim only what it can carry, and its shortest paths
stay inside its zone (``multicrane.sim.shortest_paths.distance_field`` with the crane).
"""

from __future__ import annotations

import numpy as np

from multicrane.core.codes import ASSEMBLE, CLAIM_BASE, WAIT, Status
from multicrane.sim.shortest_paths import UNREACHABLE, current_cells, distance_field, next_move
from multicrane.sim.simulator import NOBODY, Simulator


class GreedyPolicy:
    """Drive a ``MultiCraneEnv`` (or anything exposing ``.sim``) greedily."""

    def __init__(self, env, seed: int | None = 0, patience: int = 3):
        self.env = env
        self.rng = np.random.default_rng(seed)
        self.patience = patience
        self._fields: dict[int, tuple[tuple[int, ...], np.ndarray]] = {}
        self._stuck: dict[int, int] = {}

    @property
    def sim(self) -> Simulator:
        return self.env.sim

    def __call__(self, observations: dict) -> dict:
        sim = self.sim
        masks = [observations[a]["action_mask"] for a in self.env.possible_agents]
        taken: set[int] = set()
        actions = {}
        for crane, agent in enumerate(self.env.possible_agents):
            actions[agent] = self._act(sim, crane, masks[crane], taken)
        return actions

    def _act(self, sim: Simulator, crane: int, mask: np.ndarray, taken: set[int]) -> int:
        if sim.state.assembling[crane] or sim.state.pass_over[crane]:
            return WAIT
        comp = sim.state.held[crane]
        if comp == NOBODY:
            return self._claim(sim, mask, taken)
        if sim.state.status[comp] == Status.ARRIVED:
            return ASSEMBLE if mask[ASSEMBLE] else WAIT
        move = self._step_towards_target(sim, crane, comp)
        if move is not None and mask[move]:
            self._stuck[comp] = 0
            return move
        # Blocked or no path: wait and replan; after a while shake loose.
        self._fields.pop(comp, None)
        self._stuck[comp] = self._stuck.get(comp, 0) + 1
        if self._stuck[comp] > self.patience:
            moves = np.flatnonzero(mask[:WAIT])
            if len(moves):
                self._stuck[comp] = 0
                return int(moves[self.rng.integers(len(moves))])
        return WAIT

    def _step_towards_target(self, sim: Simulator, crane: int, comp: int) -> int | None:
        targets = tuple(sim.ready_targets(comp))
        if not targets:
            return None
        cached = self._fields.get(comp)
        if cached is None or cached[0] != targets:
            cached = (targets, distance_field(sim, comp, list(targets), crane))
            self._fields[comp] = cached
        dist = cached[1]
        here = current_cells(sim, comp)[0]
        if dist[here] == UNREACHABLE:
            return None
        move = next_move(sim, comp, dist)
        if move is not None and not sim.move_ok(comp, move):
            # The world changed under the cached field: search again once.
            dist = distance_field(sim, comp, list(targets), crane)
            self._fields[comp] = (targets, dist)
            move = next_move(sim, comp, dist)
        return move

    def _claim(self, sim: Simulator, mask: np.ndarray, taken: set[int]) -> int:
        best, best_cost = None, None
        for comp in np.flatnonzero(mask[CLAIM_BASE:]).tolist():
            if comp in taken:
                continue
            cost = _crow_distance(sim, comp)
            if best_cost is None or cost < best_cost:
                best, best_cost = comp, cost
        if best is None:
            return WAIT
        taken.add(best)
        return CLAIM_BASE + best


def _crow_distance(sim: Simulator, comp: int) -> int:
    """Manhattan distance from the pick-up pose to the nearest ready target (a cheap guess)."""
    here = sim.site.cell(sim.state.pickup[comp][0])
    best = None
    for t in sim.ready_targets(comp):
        there = sim.site.cell(sim.site.target_cells[t][0])
        d = sum(abs(a - b) for a, b in zip(here, there, strict=True))
        best = d if best is None else min(best, d)
    return best if best is not None else 10**6

