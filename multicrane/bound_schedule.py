"""A first schedule of the bound's relaxation, by list scheduling, for CP-SAT to start from.

Given an assignment of each component to one option (``Tasks.assignment``: least total work),
``list_schedule`` repeatedly starts the task that can start soonest (its target's supports
already scheduled), on its option's crane or the crane free soonest, and respects every
constraint of the relaxation in ``multicrane.bound``: one task at a time per crane, arrival no
earlier than the step the target's last support is assembled, and a beam claimed no earlier
than the step some target it may fill is supported. Its makespan is an upper bound on the
relaxation's optimum (not on the real problem's); when it equals the workload floor the
relaxation is solved.
"""

from __future__ import annotations

from multicrane.bound_tasks import Option, Tasks
from multicrane.types import Kind


def list_schedule(tasks: Tasks, assignment: dict[int, Option]) -> dict[int, tuple[int, int]]:
    """Component -> (start, crane) for a schedule of the relaxation with that assignment.

    Start is the step before the claim (the task occupies its crane over
    ``[start, start + duration)``). Raises ValueError if some task can never start (a target
    whose support no component fills).
    """
    n = tasks.n_cranes
    free_at = [0] * n
    fill: dict[int, int] = dict.fromkeys(tasks.prebuilt_targets, 0)
    pending = set(tasks.comps)
    plan: dict[int, tuple[int, int]] = {}
    while pending:
        best = None
        for c in sorted(pending):
            o = assignment[c]
            supports = tasks.supports[o.target]
            if any(s not in fill for s in supports):
                continue
            ready = max((fill[s] for s in supports), default=0)
            earliest = max(0, ready - 1 - o.moves)
            if tasks.scenario.components[c].kind is Kind.BEAM:
                known = [
                    max((fill[s] for s in tasks.supports[t]), default=0)
                    for t in tasks.compatible[c]
                    if all(s in fill for s in tasks.supports[t])
                ]
                earliest = max(earliest, min(known) - 1)
            crane = o.crane if o.crane is not None else min(range(n), key=free_at.__getitem__)
            start = max(earliest, free_at[crane])
            key = (start, -o.duration, c)
            if best is None or key < best[0]:
                best = (key, c, crane, start)
        if best is None:
            raise ValueError(
                f"{tasks.scenario.source}: no schedule: some target's supports are never filled"
            )
        _, c, crane, start = best
        end = start + assignment[c].duration
        plan[c] = (start, crane)
        fill[assignment[c].target] = end
        free_at[crane] = end
        pending.remove(c)
    return plan


def makespan(tasks: Tasks, assignment: dict[int, Option], plan: dict) -> int:
    """The makespan of a ``list_schedule`` plan (0 when there is nothing to place)."""
    return max((plan[c][0] + assignment[c].duration for c in plan), default=0)
