"""The bound's floors: makespans no episode beats, computed without the solver.

``floor_of(tasks)`` is the makespan's lower limit in the model of ``multicrane.bounds.makespan``
and the bound reported when the solver stops before it proves more. Without events it is the
workload floor with distinct targets or the longest task's shortest option, as before. With
events (``Tasks.has_events``) it is the largest of:

- the work floor in up steps: the least ``T`` by which the cranes have as many up steps in
  ``[0, T)`` as the least total work of an assignment (``outages.work_floor``);
- *heads*: a lower limit on when each target can be filled, from the release times, the
  breakdowns, the supports (a component arrives no earlier than its target's supports are
  filled, and is then assembled), the rule that a beam or panel is claimed only once some
  target it may fill is supported, and the closures (no claim while a cell of the
  component's yard or pick-up pose is closed, no arrival by a move made while a cell of the
  target is closed: ``Tasks.closed_lift``, ``Tasks.closed_target``); iterated to a fixed
  point from zero, so every value stays a lower limit;
- *energy after* ``r``, for every time ``r`` some head names: a task whose start cannot be
  before ``r`` does all its work after ``r``; one that starts at ``s < r`` at least
  ``duration - (r - s)``; one whose component arrives no earlier than ``r`` at least its
  ``assembly_steps``; that work needs as many up steps of the cranes after ``r`` (per
  component with its options' least duration, start and arrival, which is no more). A
  task's start here is that of its last ``duration`` up steps before its end, of which the
  ``assembly_steps`` after its arrival are part: so it is also no earlier than ``1 + moves``
  up steps of its crane before the arrival's head (``outages.counted_back``).
"""

from __future__ import annotations

import numpy as np

from multicrane.bounds.lift_options import Option, Tasks
from multicrane.bounds.outages import counted_back, finish, first_up, work_floor
from multicrane.core.kinds import waits_for_target


def floor_of(tasks: Tasks) -> int:
    """The makespan no episode of the tasks' start (and schedule) beats (see the module doc)."""
    if not tasks.has_events:
        return max([tasks.assignment_floor(), *tasks.shortest.values()])
    outages = tasks.outages or ((),) * tasks.n_cranes
    total = sum(o.duration for o in tasks.assignment().values())
    found = heads(tasks)
    _, arrive, end = found
    begun = option_heads(tasks, found)
    fill = {}
    for o in tasks.options:
        fill[o.target] = min(end[o], fill.get(o.target, end[o]))
    floors = [work_floor(outages, 0, total), *fill.values()]
    assembly = tasks.scenario.assembly_steps
    # per component, its options' least duration, start and arrival: work after r at least
    # max(duration - (r - start), assembly if arrival >= r), as for each option
    least: dict[int, tuple[int, int, int]] = {}
    for o in tasks.options:
        begins = begun[o][0]
        d, s, a = least.get(o.comp, (o.duration, begins, arrive[o]))
        least[o.comp] = (min(d, o.duration), min(s, begins), min(a, arrive[o]))
    duration, first, arrival = (np.array(v) for v in zip(*least.values(), strict=True))
    for r in sorted({*first.tolist(), *arrival.tolist()} - {0}):
        after = np.maximum(duration - np.maximum(0, r - first), assembly * (arrival >= r))
        if after.any():  # no work left after r: no floor from r
            floors.append(work_floor(outages, r, int(after.sum())))
    return max(floors)


def option_heads(tasks: Tasks, found=None) -> dict[Option, tuple[int, int]]:
    """Per option, lower limits on the start of its last ``duration`` up steps (the start
    of its task in the model) and on its end, closures included (the model has no closures
    of its own: these carry them into it). ``found``: ``heads(tasks)`` if known."""
    start, arrive, end = found or heads(tasks)
    return {o: (max(start[o], _begun(tasks, o, arrive[o])), end[o]) for o in tasks.options}


def _begun(tasks: Tasks, option: Option, arrival: int) -> int:
    """No earlier than ``1 + moves`` up steps of the option's crane before ``arrival``; an
    option for any crane counts back on each crane's breakdowns and keeps the earliest."""
    cranes = [tasks.outages_of(option.crane)]
    if option.crane is None and tasks.outages:
        cranes = list(tasks.outages)
    return min(counted_back(outages, arrival, 1 + option.moves) for outages in cranes)


def heads(tasks: Tasks) -> tuple[dict[Option, int], dict[Option, int], dict[Option, int]]:
    """Per option, lower limits on its start, its component's arrival and its end."""
    assembly = tasks.scenario.assembly_steps
    fill = dict.fromkeys(range(len(tasks.supports)), 0)  # target -> earliest fill
    waits = {c: waits_for_target(tasks.scenario.components[c].kind) for c in tasks.comps}
    while True:
        ready = [max((fill[s] for s in sup), default=0) for sup in tasks.supports]
        start, arrive, end = {}, {}, {}
        for o in tasks.options:
            due = tasks.release.get(o.comp, 0)
            if waits[o.comp]:
                due = max(due, min(ready[t] for t in tasks.compatible[o.comp]) - 1)
            outages = tasks.outages_of(o.crane)
            start[o] = _first_open(due, outages, tasks.closed_lift.get(o.comp, ()))
            arrival = max(start[o] + 1 + o.moves, ready[o.target])
            shut = tuple((a + 1, b + 1) for a, b in tasks.closed_target.get(o.target, ()))
            arrive[o] = first_up(shut, arrival)  # the move into it is made at arrival - 1
            end[o] = max(finish(outages, start[o], o.duration), arrive[o] + assembly)
        new = dict.fromkeys(range(len(tasks.supports)), 0)
        for o in tasks.options:
            new[o.target] = end[o] if new[o.target] == 0 else min(new[o.target], end[o])
        new.update(dict.fromkeys(tasks.prebuilt_targets, 0))
        if new == fill:
            return start, arrive, end
        fill = new


def _first_open(t: int, *closed: tuple[tuple[int, int], ...]) -> int:
    """The first time at or after ``t`` in none of the windows of ``closed``."""
    while (later := max(first_up(windows, t) for windows in closed)) != t:
        t = later
    return t
