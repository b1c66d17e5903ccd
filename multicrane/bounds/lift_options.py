"""The tasks of the makespan bound: each component's (crane, target) options and durations.

For the start ``reset(seed)`` draws (``start_simulator``), ``task_options`` lists, for every
component that is not pre-built, each crane (None when there is no reach) and each free
target it may fill that the crane can carry it to inside its zone, with the fewest moves of
the rigid component from its pick-up pose through the static site (walls, ground, sky and
obstacles; other components are ignored). ``Tasks.assignment`` is a least-work assignment of
the components to distinct targets (a minimum-cost matching), whose total gives the workload
floor that ``multicrane.bounds.makespan`` states. The model and its reasoning:
``multicrane.bounds.makespan``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from multicrane.core.schema import Scenario
from multicrane.sim import shortest_paths
from multicrane.sim.simulator import Simulator
from multicrane.sim.site import FREE


@dataclass(frozen=True)
class Option:
    """One way to do a task: ``crane`` (None: any crane, no reach) brings component ``comp``
    to target ``target`` in ``moves`` moves; ``duration`` = claim + moves + assembly."""

    comp: int
    target: int
    crane: int | None
    moves: int
    duration: int


@dataclass(frozen=True)
class Tasks:
    """The tasks of one episode's start: every option, the pre-built targets, the floors."""

    scenario: Scenario
    n_cranes: int
    options: tuple[Option, ...]
    comps: tuple[int, ...]  # components to place (not pre-built), in index order
    prebuilt_targets: frozenset[int]  # targets filled at step 0
    shortest: dict[int, int]  # component -> its shortest option's duration
    supports: tuple[tuple[int, ...], ...]  # per target: its support targets
    compatible: dict[int, tuple[int, ...]]  # component -> free targets it may fill

    @property
    def workload_floor(self) -> int:
        """ceil(total minimum work / cranes), each task at its shortest option."""
        return math.ceil(sum(self.shortest.values()) / self.n_cranes)

    def assignment(self) -> dict[int, Option]:
        """A least-work assignment: each component to a distinct free target, at the
        pair's shortest option (a minimum-cost matching). ValueError when there is none."""
        from ortools.graph.python import linear_sum_assignment

        targets = sorted({o.target for o in self.options})
        best: dict[tuple[int, int], Option] = {}
        for o in self.options:
            key = (self.comps.index(o.comp), targets.index(o.target))
            if key not in best or o.duration < best[key].duration:
                best[key] = o
        matcher = linear_sum_assignment.SimpleLinearSumAssignment()
        for (left, right), o in best.items():
            matcher.add_arc_with_cost(left, right, o.duration)
        for left in range(len(self.comps), len(targets)):  # targets left free cost nothing
            for right in range(len(targets)):
                matcher.add_arc_with_cost(left, right, 0)
        if len(targets) < len(self.comps) or matcher.solve() != matcher.OPTIMAL:
            raise ValueError(
                f"{self.scenario.source}: no assignment of the {len(self.comps)} components "
                f"to distinct free targets they can reach ({len(targets)} reachable targets)"
            )
        return {c: best[(left, matcher.right_mate(left))] for left, c in enumerate(self.comps)}

    def assignment_floor(self) -> int:
        """ceil(least total work of a whole assignment / cranes): the components fill
        distinct targets, so the least total is that of ``assignment()``; never below
        ``workload_floor`` and, like it, no schedule of the cranes can beat it."""
        total = sum(o.duration for o in self.assignment().values())
        return math.ceil(total / self.n_cranes)


# -- the tasks: options and their durations ----------------------------------------------------


def start_simulator(scenario: Scenario, n_cranes: int, seed: int) -> Simulator:
    """A simulator at the start ``reset(seed=seed)`` gives the multi-agent environment."""
    sim = Simulator(scenario, n_cranes=n_cranes)
    sim.reset(np.random.default_rng(seed))
    return sim


def task_options(scenario: Scenario, n_cranes: int | None = None, seed: int = 0) -> Tasks:
    """Every (component, crane, target) option of the start ``reset(seed)`` draws.

    Raises ValueError naming a component that no crane can carry to any free target it may
    fill, and when reach is given for fewer cranes than asked.
    """
    n = scenario.cranes if n_cranes is None else int(n_cranes)
    if n < 1:
        raise ValueError(f"n_cranes must be at least 1, got {n_cranes!r}")
    specs = scenario.crane_specs
    if specs and n > len(specs):
        raise ValueError(
            f"{scenario.source}: {n} cranes asked, but crane reach is given for {len(specs)}"
        )
    sim = start_simulator(scenario, n, seed)
    site, st = sim.site, sim.state
    prebuilt = frozenset(int(st.filled[c]) for c in range(site.n_components) if st.prebuilt[c])
    free = site.static == FREE
    cranes: list[int | None] = [None] if site.reach is None else list(range(n))
    options: list[Option] = []
    comps = [c for c in range(site.n_components) if not st.prebuilt[c]]
    assembly = scenario.assembly_steps
    for c in comps:
        pickup = st.pickup[c]
        offsets = [j - pickup[0] for j in pickup]
        fit = shortest_paths.fits_everywhere(free, offsets)
        targets = [t for t in site.compatible[c] if t not in prebuilt]
        goals = {t: shortest_paths.goal_positions(sim, c, [t]) for t in targets}
        found = []
        for k in cranes:
            ok = fit if k is None else fit & shortest_paths.fits_everywhere(site.reach[k], offsets)
            dist = shortest_paths.breadth_first(ok, [pickup[0]], site.move_delta)
            for t in targets:
                reached = [int(dist[g]) for g in goals[t] if dist[g] >= 0]
                if reached:
                    m = min(reached)
                    found.append(Option(c, t, k, m, 1 + m + assembly))
        if not found:
            comp = scenario.components[c]
            raise ValueError(
                f"{scenario.source}: component {comp.id!r} cannot be carried from its pick-up "
                f"pose to any free target it may fill by any of {n} crane(s) (seed {seed})"
            )
        options.extend(found)
    shortest = {c: min(o.duration for o in options if o.comp == c) for c in comps}
    compatible = {c: tuple(t for t in site.compatible[c] if t not in prebuilt) for c in comps}
    supports = tuple(tuple(s) for s in site.target_supports)
    return Tasks(
        scenario, n, tuple(options), tuple(comps), prebuilt, shortest, supports, compatible
    )
