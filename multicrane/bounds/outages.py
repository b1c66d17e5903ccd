"""Crane time under known breakdowns: when a task ends, and its CP-SAT interval that pauses.

A crane that is down during ``[a, b)`` (``multicrane.sim.events.Outage``) does nothing in the
steps ``a .. b - 1``: its held component stays, an assembly pauses and resumes afterwards
(docs/uncertainty.md). So a task of ``d`` steps of work that a crane starts at ``s`` (an up
step) ends, at the earliest, ``d`` up steps later: ``finish``. ``up_steps`` counts a crane's
up steps in a window, and ``work_floor`` is the earliest time by which ``n`` cranes can have
done an amount of work, their outages left out. ``add_paused_task`` states in CP-SAT a task on
a crane with outages: each outage lies wholly before it, wholly after it, or inside it and
lengthens it by its own length (``multicrane.bounds.makespan`` explains why that is sound).
An outage is a ``(start, end)`` pair; a crane's outages are sorted and disjoint.
"""

from __future__ import annotations

import math
from typing import Any

Window = tuple[int, int]


def first_up(outages: tuple[Window, ...], t: int) -> int:
    """The first step at or after ``t`` in which the crane is up."""
    for a, b in outages:
        if a <= t < b:
            t = b
    return t


def finish(outages: tuple[Window, ...], start: int, duration: int) -> int:
    """The end of ``duration`` up steps from ``start`` (an up step): ``start + duration``
    plus the length of every outage that begins inside the work."""
    end = start + duration
    for a, b in outages:
        if start <= a < end:
            end += b - a
    return end


def counted_back(outages: tuple[Window, ...], t: int, n: int) -> int:
    """The earliest ``S`` with at most ``n`` up steps in ``[S, t)`` (0 when there is no
    earlier up step to count): a task whose last ``n`` up steps before ``t`` are its own
    cannot have begun them before ``S``."""
    count = 0
    while t > 0:
        t -= 1
        if first_up(outages, t) == t:
            count += 1
            if count > n:
                return t + 1
    return 0


def up_steps(outages: tuple[Window, ...], t0: int, t1: int) -> int:
    """How many steps of ``[t0, t1)`` the crane is up."""
    down = sum(max(0, min(b, t1) - max(a, t0)) for a, b in outages)
    return max(0, t1 - t0) - down


def work_floor(outages: tuple[tuple[Window, ...], ...], t0: int, work: int) -> int:
    """The earliest ``T`` by which the cranes (one outage tuple each) have ``work`` up steps
    in ``[t0, T)`` together: no schedule does that much work starting at ``t0`` sooner."""
    n = len(outages)
    t = t0 + math.ceil(work / n)
    while (done := sum(up_steps(o, t0, t) for o in outages)) < work:
        t += math.ceil((work - done) / n)
    return t


def add_paused_task(model, start, duration: int, present, outages: tuple[Window, ...],
                    horizon: int, name: str) -> tuple[Any, Any, Any]:  # fmt: skip
    """A task of ``duration`` up steps on a crane with ``outages``, from ``start``, present
    when ``present``: returns ``(interval, end, used)`` (``used``: the crane time it takes
    when present, 0 when not). Each outage is, when the task is present, exactly one of: before
    it (``end <= a``), after it (``start >= b``) or inside it (``start < a``; the size grows
    by ``b - a``); so a present task never starts in an outage."""
    end = model.NewIntVar(0, horizon, f"{name}_end")
    size = model.NewIntVar(duration, horizon + duration, f"{name}_size")
    extra = []
    for j, (a, b) in enumerate(outages):
        before, inside, after = (model.NewBoolVar(f"{name}_{j}{w}") for w in "bia")
        model.Add(before + inside + after == present)
        model.Add(end <= a).OnlyEnforceIf(before)
        model.Add(start <= a - 1).OnlyEnforceIf(inside)
        model.Add(start >= b).OnlyEnforceIf(after)
        extra.append((b - a) * inside)
    model.Add(size == duration + sum(extra))
    interval = model.NewOptionalIntervalVar(start, size, end, present, f"{name}_iv")
    return interval, end, duration * present + sum(extra)
