"""A first schedule of the bound's relaxation, by list scheduling, for CP-SAT to start from.

Given an assignment of each component to a target (``Tasks.assignment``: least total work),
``list_schedule`` repeatedly starts the task that can start soonest (its target's supports
already scheduled), on the crane that can finish it soonest (among those with reach). It
respects every constraint of the relaxation in ``multicrane.bounds.makespan``: one task at a time
per
crane, arrival no earlier than the step the target's last support is assembled, and a beam
(or panel) claimed no earlier than the step some target it may fill is supported; with events,
no claim before the component is due nor while its crane is down, and a task paused by its
crane's breakdowns (``task_end``); and given ``limits`` (``floors.option_heads``), no task
starting or ending before its option's limits. Its makespan is an upper bound on the
relaxation's optimum (not on the real problem's); when it equals the workload floor the
relaxation is solved.
"""

from __future__ import annotations

from multicrane.bounds.lift_options import Option, Tasks
from multicrane.bounds.outages import finish, first_up
from multicrane.core.kinds import waits_for_target


def list_schedule(tasks: Tasks, assignment: dict[int, Option],
                  limits: dict[Option, tuple[int, int]] | None = None
                  ) -> dict[int, tuple[int, Option]]:  # fmt: skip
    """Component -> (start, option) for a schedule of the relaxation with that assignment.

    The option is the assigned target's fastest option on the crane that finishes it soonest
    (with reach, several cranes may carry a component equally fast). Start is the step before
    the claim (the task occupies its crane over ``[start, start + duration)``). Raises
    ValueError if some task can never start (a target whose support no component fills).
    """
    n = tasks.n_cranes
    free_at = [0] * n
    fill: dict[int, int] = dict.fromkeys(tasks.prebuilt_targets, 0)
    pending = set(tasks.comps)
    choices = {
        c: [o for o in tasks.options if o.comp == c and o.target == a.target]
        for c, a in assignment.items()
    }
    plan: dict[int, tuple[int, Option]] = {}
    while pending:
        best = None
        for c in sorted(pending):
            target = assignment[c].target
            supports = tasks.supports[target]
            if any(s not in fill for s in supports):
                continue
            ready = max((fill[s] for s in supports), default=0)
            claimable = 0
            if waits_for_target(tasks.scenario.components[c].kind):
                known = [
                    max((fill[s] for s in tasks.supports[t]), default=0)
                    for t in tasks.compatible[c]
                    if all(s in fill for s in tasks.supports[t])
                ]
                claimable = min(known) - 1
            due = tasks.release.get(c, 0)
            for o in choices[c]:
                crane = o.crane if o.crane is not None else min(range(n), key=free_at.__getitem__)
                earliest = max(due, ready - 1 - o.moves, claimable, free_at[crane])
                start = _first_start(tasks, o, earliest, (limits or {}).get(o, (0, 0)))
                key = (start, task_end(tasks, start, o), -o.duration, c, crane)
                if best is None or key < best[0]:
                    best = (key, c, crane, start, o)
        if best is None:
            raise ValueError(
                f"{tasks.scenario.source}: no schedule: some target's supports are never filled"
            )
        (_, end, *_), c, crane, start, o = best
        plan[c] = (start, o)
        fill[o.target] = free_at[crane] = end
        pending.remove(c)
    return plan


def _first_start(tasks: Tasks, option: Option, earliest: int, limit: tuple[int, int]) -> int:
    """The first up step of the option's crane at or after ``earliest`` and the start limit
    from which the task ends no earlier than the end limit."""
    outages = tasks.outages_of(option.crane)
    start = first_up(outages, max(earliest, limit[0]))
    while task_end(tasks, start, option) < limit[1]:
        start = first_up(outages, start + 1)
    return start


def task_end(tasks: Tasks, start: int, option: Option) -> int:
    """The end of the option's task started at ``start``, paused by its crane's breakdowns."""
    return finish(tasks.outages_of(option.crane), start, option.duration)


def makespan(tasks: Tasks, plan: dict[int, tuple[int, Option]]) -> int:
    """The makespan of a ``list_schedule`` plan (0 when there is nothing to place)."""
    return max((task_end(tasks, start, o) for start, o in plan.values()), default=0)
