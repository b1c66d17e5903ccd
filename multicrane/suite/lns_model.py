"""One large-neighbourhood move: CP-SAT re-plans a set of freed tasks around the rest of a plan.

``propose(tasks, plan, timing, freed, ...)`` builds the scheduling relaxation of
``multicrane.bounds.makespan`` (tasks of claim + moves + assembly, cranes one task at a time,
a target filled once, arrival no earlier than its supports are assembled, a beam or panel
claimed no earlier than some target it may fill is supported) restricted to a neighbourhood
of the incumbent plan, and returns the plan its solution gives (per crane, the tasks by start
step; no releases) or None when it found nothing.

- A task outside ``freed`` keeps its crane and target, and its crane's fixed tasks keep
  their order (each ends before the next starts); its duration is the one the simulator
  took (``timing``: waits and detours included), counted in its crane's up steps.
- A freed task may take any crane and any free target it may fill, at any place in the
  cranes' orders; an option's duration is its relaxed one scaled by how much longer the
  simulator took than the relaxation for that component's incumbent option.
- With site events (``tasks`` made with ``events``) the model knows them as the bound does:
  a late component starts no earlier than it is due, a crane's breakdown pauses the task it
  holds (``multicrane.bounds.outages.add_paused_task``), and a component is not claimed
  while a closure takes a cell of its yard or pick-up pose. Here these only steer the
  proposals (the simulator judges them), so they need not be a relaxation.

So the incumbent's simulated schedule is a solution of the model (it is given as the hint)
and its objective is the simulated makespan. The objective is the makespan, then the sum of
the tasks' ends (so a move that cannot shorten the makespan still packs the tasks earlier).
The simulator decides whether the proposal is better (``multicrane.suite.lns``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from multicrane.bounds.lift_options import Tasks
from multicrane.bounds.outages import Window, add_paused_task, up_steps
from multicrane.core.kinds import waits_for_target
from multicrane.suite.plan import Plan, Step, Timing


@dataclass
class _Vars:
    """The model and its variables."""

    model: Any
    horizon: int
    start: dict[int, Any] = field(default_factory=dict)
    end: dict[int, Any] = field(default_factory=dict)
    fill: dict[int, Any] = field(default_factory=dict)  # free target -> the step it is filled
    chosen: dict[tuple[int, int, int], Any] = field(default_factory=dict)  # (c, t, k) -> bool


def choices_of(tasks: Tasks) -> dict[int, dict[tuple[int, int], int]]:
    """Component -> {(target, crane): relaxed duration} of its options, every crane spelled
    out (an option of any crane, without reach, is one choice per crane)."""
    out: dict[int, dict[tuple[int, int], int]] = {c: {} for c in tasks.comps}
    for o in tasks.options:
        for k in range(tasks.n_cranes) if o.crane is None else (o.crane,):
            out[o.comp][(o.target, k)] = o.duration
    return out


def crane_outages(tasks: Tasks, crane: int) -> tuple[Window, ...]:
    """The breakdowns of ``crane`` (none without events)."""
    return tasks.outages[crane] if tasks.outages else ()


def durations(relaxed: dict[int, dict[tuple[int, int], int]], plan: Plan,
              timing: dict[int, Timing], freed: set[int],
              outages: tuple[tuple[Window, ...], ...] = ()
              ) -> dict[int, dict[tuple[int, int], int]]:  # fmt: skip
    """Component -> {(target, crane): duration} of its choices in the model (module doc),
    from the relaxed durations (``choices_of``); ``outages``: per crane its breakdowns,
    whose steps a task's simulated duration does not count."""
    placed = {s.comp: (s.target, k) for k, steps in enumerate(plan) for s in steps}
    out: dict[int, dict[tuple[int, int], int]] = {}
    for c, choices in relaxed.items():
        when = timing[c]
        took = up_steps(outages[when.crane] if outages else (), when.start, when.end)
        mine = placed[c]
        if c not in freed:
            out[c] = {mine: took}
            continue
        scale = took / choices.get(mine, took)
        out[c] = {key: max(1, round(d * scale)) for key, d in choices.items()}
    return out


def propose(tasks: Tasks, relaxed: dict[int, dict[tuple[int, int], int]], plan: Plan,
            timing: dict[int, Timing], freed: set[int], time_limit: float, seed: int = 0,
            rank: dict[int, int] | None = None) -> Plan | None:  # fmt: skip
    """A plan in which CP-SAT re-placed the ``freed`` tasks (see the module doc);
    ``relaxed``: ``choices_of(tasks)``."""
    from ortools.sat.python import cp_model

    choices = durations(relaxed, plan, timing, freed, tasks.outages)
    makespan_now = max(t.end for t in timing.values())
    horizon = 2 * makespan_now + max(d for ch in choices.values() for d in ch.values())
    v = _Vars(cp_model.CpModel(), horizon)
    makespan = v.model.NewIntVar(0, horizon, "makespan")
    by_crane = _add_tasks(v, tasks, choices, makespan, makespan_now)
    _add_readiness(v, tasks, choices)
    _keep_fixed_orders(v, plan, freed)
    for items in by_crane.values():
        v.model.AddNoOverlap(items)
    weight = len(tasks.comps) * horizon + 1
    v.model.Minimize(weight * makespan + sum(v.end.values()))
    _hint(v, plan, timing)
    solver = cp_model.CpSolver()
    solver.parameters.max_time_in_seconds = float(time_limit)
    solver.parameters.num_workers = 1
    solver.parameters.random_seed = int(seed)
    if solver.Solve(v.model) not in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        return None
    lists: list[list[tuple[int, int, int]]] = [[] for _ in range(tasks.n_cranes)]
    for (c, t, k), var in v.chosen.items():
        if solver.BooleanValue(var):
            lists[k].append((solver.Value(v.start[c]), (rank or {}).get(c, c), c, t))
    return tuple(tuple(Step(c, t) for *_, c, t in sorted(x)) for x in lists)


def _add_tasks(v: _Vars, tasks: Tasks, choices: dict, makespan, makespan_now: int
               ) -> dict[int, list]:  # fmt: skip
    """Each component one choice; each free target filled once; the cranes' intervals."""
    model, horizon = v.model, v.horizon
    free_targets = [t for t in range(len(tasks.supports)) if t not in tasks.prebuilt_targets]
    v.fill = {t: model.NewIntVar(0, horizon, f"fill_{t}") for t in free_targets}
    by_target: dict[int, list] = {t: [] for t in free_targets}
    by_crane: dict[int, list] = {}
    # only breakdowns that begin before the incumbent's makespan: a schedule no longer than it
    # (the hint is one) meets no other
    outages = [tuple(w for w in crane_outages(tasks, k) if w[0] < makespan_now)
               for k in range(tasks.n_cranes)]  # fmt: skip
    for c, ch in choices.items():
        v.start[c] = model.NewIntVarFromDomain(open_times(tasks, c, horizon), f"start_{c}")
        v.end[c] = model.NewIntVar(0, horizon, f"end_{c}")
        model.Add(makespan >= v.end[c])
        here = []
        for (t, k), d in ch.items():
            p = model.NewBoolVar(f"p_{c}_{t}_{k}")
            v.chosen[(c, t, k)] = p
            here.append(p)
            by_target[t].append(p)
            if outages[k]:
                iv, ends, _ = add_paused_task(model, v.start[c], d, p, outages[k], horizon,
                                              f"o_{c}_{t}_{k}")  # fmt: skip
                model.Add(v.end[c] == ends).OnlyEnforceIf(p)
            else:
                iv = model.NewOptionalFixedSizeIntervalVar(v.start[c], d, p, f"iv_{c}_{t}_{k}")
                model.Add(v.end[c] == v.start[c] + d).OnlyEnforceIf(p)
            by_crane.setdefault(k, []).append(iv)
            model.Add(v.fill[t] == v.end[c]).OnlyEnforceIf(p)
        model.AddExactlyOne(here)
    for ps in by_target.values():
        model.AddExactlyOne(ps)
    return by_crane


def open_times(tasks: Tasks, comp: int, horizon: int):
    """The start steps the component may have: from the step it is due, outside the
    closures of its yard or pick-up cells."""
    from ortools.sat.python import cp_model

    free, t = [], tasks.release.get(comp, 0)
    for a, b in sorted(tasks.closed_lift.get(comp, ())):
        if a > t:
            free.append([t, min(a, horizon + 1) - 1])
        t = max(t, b)
    free.append([t, horizon])
    return cp_model.Domain.FromIntervals([w for w in free if w[0] <= w[1]])


def _add_readiness(v: _Vars, tasks: Tasks, choices: dict) -> None:
    """Arrival (the end less the assembly) no earlier than the target's supports are
    filled; a beam or panel claimed no earlier than some target it may fill is ready."""
    model, assembly = v.model, tasks.scenario.assembly_steps
    ready: dict[int, Any] = {}
    for t in v.fill:
        times = [v.fill[s] for s in tasks.supports[t] if s in v.fill]
        ready[t] = 0 if not times else model.NewIntVar(0, v.horizon, f"ready_{t}")
        if times:
            model.AddMaxEquality(ready[t], times)
    for (c, t, _), p in v.chosen.items():
        if not isinstance(ready[t], int):
            model.Add(v.end[c] - assembly >= ready[t]).OnlyEnforceIf(p)
    for c in choices:
        if not waits_for_target(tasks.scenario.components[c].kind):
            continue
        compatible = [ready[t] for t in tasks.compatible[c]]
        if any(isinstance(r, int) for r in compatible):
            continue
        earliest = model.NewIntVar(0, v.horizon, f"claimable_{c}")
        model.AddMinEquality(earliest, compatible)
        model.Add(v.start[c] + 1 >= earliest)


def _keep_fixed_orders(v: _Vars, plan: Plan, freed: set[int]) -> None:
    """On each crane, the tasks that are not freed keep their order."""
    for steps in plan:
        kept = [s.comp for s in steps if s.comp not in freed]
        for a, b in zip(kept, kept[1:], strict=False):
            v.model.Add(v.end[a] <= v.start[b])


def _hint(v: _Vars, plan: Plan, timing: dict[int, Timing]) -> None:
    """The incumbent's simulated schedule as the solver's starting point."""
    model = v.model
    placed = {s.comp: (s.target, k) for k, steps in enumerate(plan) for s in steps}
    for (c, t, k), p in v.chosen.items():
        model.AddHint(p, placed[c] == (t, k))
    for c, when in timing.items():
        if c in v.start:
            model.AddHint(v.start[c], when.start)
            model.AddHint(v.end[c], when.end)
            model.AddHint(v.fill[placed[c][0]], when.end)
