"""The CP-SAT model of the makespan bound's relaxation: tasks, readiness, cranes, the hint.

``multicrane.bounds.makespan`` states the relaxation and its cuts and solves it; this module
builds it. ``model_of(tasks, hint)`` returns the model with its variables (each component's
``start`` and ``end``, each option's ``presence``, each free target's ``fill``, the
``makespan``), so that other searches (``multicrane.suite.lns_model``) can add to it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from multicrane.bounds.first_schedule import makespan as schedule_makespan
from multicrane.bounds.first_schedule import task_end
from multicrane.bounds.floors import floor_of, option_heads
from multicrane.bounds.lift_options import Option, Tasks
from multicrane.bounds.outages import add_paused_task
from multicrane.core.kinds import waits_for_target


@dataclass
class _Model:
    """The CP-SAT model of the relaxation as it is built, and its variables."""

    model: Any
    by_comp: dict[int, list[Option]]  # component -> its options
    horizon: int
    free_targets: list[int]  # targets not taken by a pre-built component
    makespan: Any = None
    fill: dict[int, Any] = field(default_factory=dict)  # target -> the step it is filled
    start: dict[int, Any] = field(default_factory=dict)  # component -> its claim's start
    end: dict[int, Any] = field(default_factory=dict)
    presence: dict[Option, Any] = field(default_factory=dict)  # option -> chosen
    intervals: list[Any] = field(default_factory=list)
    by_crane: dict[int | None, list[tuple[Any, Option, Any]]] = field(default_factory=dict)
    paused: set[Option] = field(default_factory=set)  # options on a crane with breakdowns
    floor: int = 0  # the makespan's lower limit (floors.floor_of)


def limits_of(tasks: Tasks) -> dict[Option, tuple[int, int]]:
    """With events, each option's start and end limits (``floors.option_heads``), else none."""
    return option_heads(tasks) if tasks.has_events else {}


def build_model(tasks: Tasks, hint: dict[int, tuple[int, Option]] | None = None):
    """The CP-SAT model of the relaxation (see the module doc); returns (model, makespan).

    ``hint``: component -> (start, option) of a schedule of the relaxation
    (``multicrane.bounds.first_schedule.list_schedule``), given to the solver as a starting point.
    """
    m = model_of(tasks, hint)
    return m.model, m.makespan


def model_of(tasks: Tasks, hint: dict[int, tuple[int, Option]] | None = None) -> _Model:
    """``build_model``'s model with its variables (``start`` and ``presence`` give a schedule)."""
    from ortools.sat.python import cp_model

    m = _start_model(cp_model.CpModel(), tasks, hint)
    _add_tasks(m, tasks)
    _add_readiness(m, tasks)
    _add_cranes(m, tasks.n_cranes)
    m.model.Minimize(m.makespan)
    if hint is not None:
        _add_hint(m, tasks, hint)
    return m


def _start_model(model, tasks: Tasks, hint: dict[int, tuple[int, Option]] | None) -> _Model:
    """The options by component, the horizon, the makespan and a fill time per free target.

    The horizon is that of one crane doing every task at its longest option, after the last
    release, the last closure and its own breakdowns; with events and a hint, the hint's
    makespan (a schedule of the model: the optimum is no later), which keeps the breakdowns
    the model states few."""
    by_comp: dict[int, list[Option]] = {c: [] for c in tasks.comps}
    for o in tasks.options:
        by_comp[o.comp].append(o)
    horizon = sum(max(o.duration for o in opts) for opts in by_comp.values())
    if tasks.has_events:
        horizon += max(tasks.release.values(), default=0)
        horizon += max((sum(b - a for a, b in o) for o in tasks.outages), default=0)
        closures = [*tasks.closed_lift.values(), *tasks.closed_target.values()]
        horizon += max((b for windows in closures for _, b in windows), default=0)
        if hint is not None:
            horizon = schedule_makespan(tasks, hint)
    floor = floor_of(tasks)
    makespan = model.NewIntVar(floor, max(horizon, floor), "makespan")
    free_targets = [t for t in range(len(tasks.supports)) if t not in tasks.prebuilt_targets]
    if len(free_targets) != len(tasks.comps):
        raise ValueError(
            f"{tasks.scenario.source}: {len(tasks.comps)} components to place on "
            f"{len(free_targets)} free targets"
        )
    m = _Model(model, by_comp, horizon, free_targets, makespan, floor=floor)
    m.fill = {t: model.NewIntVar(0, horizon, f"fill_{t}") for t in free_targets}
    return m


def _add_tasks(m: _Model, tasks: Tasks) -> None:
    """Each component one task of one option (crane, target); each free target filled once;
    a late component claimed no earlier than it is due; breakdowns pause their crane's task;
    with events, each option's heads (``floors.option_heads``: closures included) as limits
    on its start and end."""
    model, horizon, start, end = m.model, m.horizon, m.start, m.end
    limits = limits_of(tasks)
    for c, opts in m.by_comp.items():
        first = min(limits[o][0] for o in opts) if limits else 0
        start[c] = model.NewIntVar(max(tasks.release.get(c, 0), first), horizon, f"start_{c}")
        end[c] = model.NewIntVar(0, horizon, f"end_{c}")
        model.Add(m.makespan >= end[c])
        for o in opts:
            p = model.NewBoolVar(f"p_{c}_{o.target}_{o.crane}")
            m.presence[o] = p
            if o in limits:
                model.Add(start[c] >= limits[o][0]).OnlyEnforceIf(p)
                model.Add(end[c] >= limits[o][1]).OnlyEnforceIf(p)
            outages = tuple(w for w in tasks.outages_of(o.crane) if w[0] < horizon)
            if outages:
                name = f"o_{c}_{o.target}_{o.crane}"
                iv, ends, size = add_paused_task(model, start[c], o.duration, p, outages,
                                                 horizon, name)  # fmt: skip
                model.Add(end[c] == ends).OnlyEnforceIf(p)
                m.paused.add(o)
            else:
                iv = model.NewOptionalFixedSizeIntervalVar(start[c], o.duration, p, f"iv_{o}")
                model.Add(end[c] == start[c] + o.duration).OnlyEnforceIf(p)
                size = o.duration * p
            m.intervals.append(iv)
            m.by_crane.setdefault(o.crane, []).append((iv, o, size))
            model.Add(m.fill[o.target] == end[c]).OnlyEnforceIf(p)
        model.AddExactlyOne(m.presence[o] for o in opts)
    for t in m.free_targets:  # as many components as free targets: each filled once
        model.AddExactlyOne(m.presence[o] for o in tasks.options if o.target == t)


def _add_readiness(m: _Model, tasks: Tasks) -> None:
    """A target is supported from the step its last support is assembled: a component
    arrives no earlier, and a beam or panel is claimed no earlier than some target it may
    fill is supported."""
    model, horizon = m.model, m.horizon
    ready = {}
    for t in m.free_targets:
        times = [m.fill[s] for s in tasks.supports[t] if s in m.fill]
        if not times:
            ready[t] = 0
        elif len(times) == 1:
            ready[t] = times[0]
        else:
            ready[t] = model.NewIntVar(0, horizon, f"ready_{t}")
            model.AddMaxEquality(ready[t], times)
    assembly = tasks.scenario.assembly_steps
    for o, p in m.presence.items():
        if isinstance(ready[o.target], int):
            continue
        if o in m.paused:  # it arrives before its last assembly_steps up steps
            model.Add(m.end[o.comp] - assembly >= ready[o.target]).OnlyEnforceIf(p)
        else:
            model.Add(m.start[o.comp] + 1 + o.moves >= ready[o.target]).OnlyEnforceIf(p)
    for c in tasks.comps:
        if not waits_for_target(tasks.scenario.components[c].kind):
            continue
        compatible = [ready[t] for t in tasks.compatible[c]]
        if any(isinstance(r, int) for r in compatible):
            continue  # some target it may fill is supported from the start
        earliest = model.NewIntVar(0, horizon, f"claimable_{c}")
        model.AddMinEquality(earliest, compatible)
        model.Add(m.start[c] + 1 >= earliest)


def _add_cranes(m: _Model, n: int) -> None:
    """Identical cranes as one cumulative resource, cranes with reach one by one."""
    model, makespan = m.model, m.makespan
    model.AddCumulative(m.intervals, [1] * len(m.intervals), n)
    model.Add(n * makespan >= sum(size for items in m.by_crane.values() for _, _, size in items))
    if None not in m.by_crane:
        for items in m.by_crane.values():
            model.AddNoOverlap(iv for iv, _, _ in items)
            model.Add(makespan >= sum(size for _, _, size in items))


def _add_hint(m: _Model, tasks: Tasks, hint: dict[int, tuple[int, Option]]) -> None:
    """A schedule of the relaxation as the solver's starting point."""
    model = m.model
    for c, (s, chosen) in hint.items():
        end = task_end(tasks, s, chosen)
        model.AddHint(m.start[c], s)
        model.AddHint(m.end[c], end)
        model.AddHint(m.fill[chosen.target], end)
        for o in m.by_comp[c]:
            model.AddHint(m.presence[o], o == chosen)
    model.AddHint(m.makespan, max(schedule_makespan(tasks, hint), m.floor))
