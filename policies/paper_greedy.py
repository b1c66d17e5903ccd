"""Greedy baseline of the single-agent mode: the current component takes a shortest path
to the nearest free target it can fill (ties: the target listed first)."""

from __future__ import annotations

from multicrane.envs.paper_env import PaperAssemblyEnv
from multicrane.sim.shortest_paths import field_from, goal_positions, path_to
from multicrane.sim.simulator import NOBODY


class PaperGreedyPolicy:
    """Call with an observation; it reads the environment's simulator (a planner)."""

    def __init__(self, env: PaperAssemblyEnv):
        self.env = env
        self._moves: list[int] = []
        self._key: tuple | None = None

    def __call__(self, observation=None) -> int:
        sim = self.env.unwrapped.sim
        comp = sim.state.held[0]
        if sim.state.pass_over[0] or comp == NOBODY:
            return 0  # the step's action is ignored
        key = (comp, sim.state.step_count)
        if self._key is None or self._key[0] != comp or not self._moves:
            self._moves = self._plan(sim, comp)
        self._key = key
        return self._moves.pop(0) if self._moves else 0

    @staticmethod
    def _plan(sim, comp: int) -> list[int]:
        goals = [goal_positions(sim, comp, [t]) for t in sim.ready_targets(comp)]
        stops = {g[0] for g in goals if g}
        dist = field_from(sim, comp, sorted(stops))
        reachable = [
            (int(dist[g[0]]), i, g[0]) for i, g in enumerate(goals) if g and dist[g[0]] >= 0
        ]
        if not reachable:
            return []
        _, _, goal = min(reachable)
        return path_to(sim, dist, goal, stops) or [0]
