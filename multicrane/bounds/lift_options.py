"""The tasks of the makespan bound: each component's (crane, target) options and durations.

For the start ``reset(seed)`` draws (``start_simulator``), ``task_options`` lists, for every
component that is not pre-built, each crane (None when there is no reach) and each free
target it may fill that the crane can carry it to inside its zone, with the fewest moves of
the rigid component from its pick-up pose through the static site (walls, ground, sky and
obstacles; other components are ignored). ``Tasks.assignment`` is a least-work assignment of
the components to distinct targets (a minimum-cost matching), whose total gives the workload
floor that ``multicrane.bounds.makespan`` states. The model and its reasoning:
``multicrane.bounds.makespan``.

With site events (``events``: a level of ``multicrane.sim.events.LEVELS`` or an ``EventSpec``)
the episode's schedule is drawn from the reset seed exactly as the environment draws it (or
given: an ``EventSchedule``, a record's), and
the tasks know it in hindsight: ``Tasks.release`` (the step each component is due on site)
and ``Tasks.outages`` (per crane, its breakdowns). Cranes with breakdowns are not
interchangeable, so the options are then per crane even without reach; where that would
make more than ``MAX_CRANE_OPTIONS`` options (large sites with interchangeable targets), the
options stay for any crane and only the work floor counts the breakdowns (a weaker, still
sound, bound).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from multicrane.bounds.outages import Window, finish, first_up
from multicrane.core.schema import Scenario
from multicrane.sim import shortest_paths
from multicrane.sim.events import EventSchedule, EventSpec, resolve
from multicrane.sim.simulator import Simulator
from multicrane.sim.site import FREE

MAX_CRANE_OPTIONS = 20_000  # per-crane options stated for breakdowns without reach, at most


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
    release: dict[int, int] = field(default_factory=dict)  # component -> step due (else 0)
    outages: tuple[tuple[Window, ...], ...] = ()  # per crane: its breakdowns (none: empty)
    closed_lift: dict[int, tuple[Window, ...]] = field(default_factory=dict)  # no claim then
    closed_target: dict[int, tuple[Window, ...]] = field(default_factory=dict)  # no arrival

    @property
    def has_events(self) -> bool:
        """True when some component is late, some crane breaks down or some closure takes
        a cell of a yard or pick-up pose or of a target."""
        return any(self.release.values()) or any(self.outages) or bool(
            self.closed_lift or self.closed_target
        )

    def outages_of(self, crane: int | None) -> tuple[Window, ...]:
        """The breakdowns of ``crane`` (none for ``None``: options for any crane, stated
        when no crane breaks down or when per-crane options would be too many)."""
        return () if crane is None or not self.outages else self.outages[crane]

    def earliest_end(self, option: Option) -> int:
        """The soonest the option can end: started when its component is due and its crane
        is up, paused by the crane's breakdowns."""
        outages = self.outages_of(option.crane)
        start = first_up(outages, self.release.get(option.comp, 0))
        return finish(outages, start, option.duration)

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


def start_simulator(
    scenario: Scenario, n_cranes: int, seed: int,
    events: str | EventSpec | EventSchedule | None = None,
) -> Simulator:  # fmt: skip
    """A simulator at the start ``reset(seed=seed)`` gives the multi-agent environment (with
    a level or an ``EventSpec``, as ``MultiCraneEnv(events=events)`` with its default step
    limit: the same start and the same site-event schedule; with an ``EventSchedule``, the
    same start and that schedule)."""
    given = events if isinstance(events, EventSchedule) else None
    spec = None if events is None or given is not None else resolve(events, scenario)
    sim = Simulator(scenario, n_cranes=n_cranes, events=spec)
    sim.reset(np.random.default_rng(seed), schedule=given)
    return sim


def task_options(
    scenario: Scenario,
    n_cranes: int | None = None,
    seed: int = 0,
    events: str | EventSpec | EventSchedule | None = None,
) -> Tasks:
    """Every (component, crane, target) option of the start ``reset(seed)`` draws, and with
    ``events`` the schedule's release times and breakdowns (see the module doc).

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
    sim = start_simulator(scenario, n, seed, events)
    site, st = sim.site, sim.state
    prebuilt = frozenset(int(st.filled[c]) for c in range(site.n_components) if st.prebuilt[c])
    free = site.static == FREE
    release, outages = _hindsight(sim)
    closed_lift, closed_target = _closed_windows(sim)
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
        distances = {}  # zone (None: the whole site) -> moves from the pick-up pose
        for k in cranes:
            zone = None if k is None or site.reach is None else k
            if zone not in distances:
                ok = fit if zone is None else fit & shortest_paths.fits_everywhere(
                    site.reach[zone], offsets)  # fmt: skip
                distances[zone] = shortest_paths.breadth_first(ok, [pickup[0]], site.move_delta)
            dist = distances[zone]
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
    if site.reach is None and any(outages) and len(options) * n <= MAX_CRANE_OPTIONS:
        options = [replace(o, crane=k) for o in options for k in range(n)]  # each a machine
    shortest: dict[int, int] = {}
    for o in options:
        shortest[o.comp] = min(o.duration, shortest.get(o.comp, o.duration))
    compatible = {c: tuple(t for t in site.compatible[c] if t not in prebuilt) for c in comps}
    supports = tuple(tuple(s) for s in site.target_supports)
    return Tasks(
        scenario, n, tuple(options), tuple(comps), prebuilt, shortest, supports, compatible,
        {c: release.get(c, 0) for c in comps}, outages, closed_lift, closed_target,
    )  # fmt: skip


def _hindsight(sim: Simulator) -> tuple[dict[int, int], tuple[tuple[Window, ...], ...]]:
    """The schedule's release time per late component and breakdowns per crane (none
    without events); closures: ``_closed_windows``."""
    schedule = sim.schedule
    if schedule is None:
        return {}, ()
    release = {c: int(a) for c, a in enumerate(schedule.arrival) if a > 0}
    outages = tuple(
        tuple(sorted((o.start, o.end) for o in schedule.outages if o.crane == k))
        for k in range(sim.n_cranes)
    )
    return release, outages


def _closed_windows(sim: Simulator) -> tuple[dict[int, tuple[Window, ...]], dict]:
    """Per component, the closures ``[a, b)`` of a cell of its yard or pick-up pose (it is
    not claimed at a time ``a <= s < b``); per target, those of one of its cells (no move
    or lift made at such a time fills it). Only cells that some closure takes."""
    schedule, site, st = sim.schedule, sim.site, sim.state
    if schedule is None or not schedule.closures:
        return {}, {}

    def windows(cells) -> tuple[Window, ...]:
        cells = set(cells)
        return tuple(sorted((k.start, k.end) for k in schedule.closures if cells & set(k.cells)))

    lift = {c: windows([*st.cells[c], *st.pickup[c]]) for c in range(site.n_components)
            if not st.prebuilt[c]}  # fmt: skip
    target = {t: windows(cells) for t, cells in enumerate(site.target_cells)}
    return {c: w for c, w in lift.items() if w}, {t: w for t, w in target.items() if w}
