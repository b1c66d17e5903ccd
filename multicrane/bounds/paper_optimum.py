"""The exact planner of the single-agent benchmark mode: the best achievable return.

In the paper's process the agent never chooses which component comes next; it only moves
the current one. Every step costs, moves past the 15th cost more, and arrival pays an amount
that depends only on how many components have arrived. So for one component a shorter path
is always better, and what is left to choose is which target each component fills when
targets are interchangeable, which changes the paths (and the pointer's skips) of all later
components. ``plan`` searches those choices exhaustively, depth first, with memoisation on
the state that matters for the future (filled targets, arrived components, pointer, pass-
over), following a shortest collision-free path for each choice
(``multicrane.sim.shortest_paths``). Paths
never pass through the pose of another target the component could fill, since it would
arrive there. The return of every branch is summed by the environment's own reward function
on a simulator, so the plan replays through the environment to exactly its return.

    from multicrane.bounds.paper_optimum import plan
    p = plan("E2S2", seed=0)
    p.episode_return, p.steps, p.actions
"""

from __future__ import annotations

from dataclasses import dataclass

from multicrane.envs.paper_env import PaperAssemblyEnv
from multicrane.envs.reward import step_reward
from multicrane.sim.shortest_paths import field_from, goal_positions, path_to
from multicrane.sim.simulator import NOBODY, Simulator


@dataclass(frozen=True)
class Plan:
    """An optimal episode: its actions, return, steps, and the target each component took."""

    config: str | None
    seed: int | None
    actions: tuple[int, ...]
    episode_return: float
    steps: int
    success: bool
    targets: tuple[tuple[str, str], ...]  # (component id, id of the target it filled)
    states_searched: int


def plan(
    config: str | None = None, seed: int | None = None, *, env: PaperAssemblyEnv | None = None
) -> Plan:
    """Plan the episode that ``PaperAssemblyEnv(config).reset(seed=seed)`` starts.

    Pass ``env`` instead (already reset) to plan from its current state, e.g. for a scenario
    of your own. The environment is left as it was.
    """
    if env is None:
        env = PaperAssemblyEnv(config)
        env.reset(seed=seed)
    search = _Search(env.sim)
    snap = env.sim.snapshot()
    try:
        value, actions = search.best()
        if env.sim.state.step_count + len(actions) > env.scenario.step_limit:
            # The unconstrained optimum runs past the step limit: search again with the
            # step count in the state, so that truncation is accounted for exactly.
            search = _Search(env.sim, limit_aware=True)
            value, actions = search.best()
        episode_return, targets, success = _replay(env.sim, actions)
        assert abs(episode_return - value) < 1e-9, "search and replay disagree"
    finally:
        env.sim.restore(snap)
    return Plan(
        config=config,
        seed=seed,
        actions=tuple(actions),
        episode_return=episode_return,
        steps=len(actions),
        success=success,
        targets=targets,
        states_searched=len(search.memo),
    )


class _Search:
    def __init__(self, sim: Simulator, limit_aware: bool = False):
        self.sim = sim
        self.limit = sim.scenario.step_limit
        self.limit_aware = limit_aware
        self.memo: dict[tuple, tuple[float, list[int]]] = {}

    def key(self) -> tuple:
        sim = self.sim
        return (
            sim.state.pointer,
            sim.state.held[0],
            sim.state.pass_over[0],
            frozenset(sim.state.passed_over),
            sim.state.status.tobytes(),
            (sim.state.filled_by >= 0).tobytes(),
            sim.state.step_count if self.limit_aware else 0,
        )

    def best(self) -> tuple[float, list[int]]:
        """The best return from the current state on, and the actions that achieve it."""
        sim = self.sim
        if sim.done or sim.state.step_count >= self.limit:
            return 0.0, []
        key = self.key()
        if key in self.memo:
            return self.memo[key]
        if sim.state.pass_over[0]:  # the action is ignored; any will do
            result = self._follow([0])
        else:
            comp = sim.state.held[0]
            if comp == NOBODY:
                raise RuntimeError("the crane has nothing to do; the scenario cannot be finished")
            result = None
            for moves in self._options(comp):
                value, actions = self._follow(moves)
                if (
                    result is None
                    or value > result[0]
                    or (value == result[0] and len(actions) < len(result[1]))
                ):
                    result = (value, actions)
            if result is None:  # no target reachable: the rest of the episode is waiting
                result = self._follow([0] * (self.limit - sim.state.step_count))
        self.memo[key] = result
        return result

    def _options(self, comp: int) -> list[list[int]]:
        """A shortest path to each reachable target the component may fill now."""
        sim = self.sim
        targets = sim.ready_targets(comp)
        goals = [goal_positions(sim, comp, [t]) for t in targets]
        stops = {g[0] for g in goals if g}
        dist = field_from(sim, comp, sorted(stops))
        options = []
        for g in goals:
            if g and dist[g[0]] >= 0:
                moves = path_to(sim, dist, g[0], stops)
                options.append(moves or [0])  # lifted straight onto a target: any action
        return options

    def _follow(self, moves: list[int]) -> tuple[float, list[int]]:
        """Apply moves (stopping at the end of the episode), then search on; undo."""
        sim = self.sim
        snap = sim.snapshot()
        total = 0.0
        taken = []
        for m in moves:
            out = sim.step([m])
            total += step_reward(sim, out)[0]
            taken.append(m)
            if sim.done or sim.state.step_count >= self.limit:
                break
        value, rest = self.best()
        sim.restore(snap)
        return total + value, taken + rest


def _replay(sim: Simulator, actions: list[int]) -> tuple[float, tuple[tuple[str, str], ...], bool]:
    """Play the actions; the return is summed step by step, as an agent would see it."""
    ids = sim.scenario.ids
    total = 0.0
    for a in actions:
        total += step_reward(sim, sim.step([a]))[0]
    filled = tuple(
        (ids[c], ids[int(sim.state.filled[c])])
        for c in range(sim.site.n_components)
        if sim.state.filled[c] >= 0 and not sim.state.prebuilt[c]
    )
    return total, filled, sim.done

