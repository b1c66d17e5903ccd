"""The task book for one copy, compiled: masks, choices, held tasks, completion, probes.

Each function is the method of ``multicrane.tasks.book.TaskBook`` it is named after, without
site events, on ``TaskState``'s arrays: ``allows`` and ``write_masks`` (a task is allowed when
its component is claimable and its target ready, neither is another crane's task's, and the
crane's static path exists), ``choose`` (a round's choices: the probes first, then in crane
order; a task no longer allowed is refused), ``motion`` (held tasks retried, then the
carrier's actions), ``after_step`` (dropped and finished tasks), ``any_open`` and
``feasible`` (a planner's probe: the plan found is kept for the crane until ``choose``).
Task events are counted per crane in ``TaskBuffers.task_counts`` (``TASK_EVENTS`` order).
"""

from __future__ import annotations

from multicrane.vector.compiled import inlined, kernel
from multicrane.vector.motion_rules import claimable
from multicrane.vector.task_carrier import (
    begin,
    cancel,
    carrier_time_left,
    planned,
    reset_carrier,
    try_start,
)

STARTED, HELD, DROPPED, REFUSED, DONE = range(5)  # ``infos.TASK_EVENTS`` order
ASSEMBLED = 3


@kernel
def reset_book(tt, b):
    """``TaskBook.reset`` (the static lengths are written apart): no tasks, no plans."""
    reset_carrier(tt, b)
    for k in range(tt.task.shape[1]):
        tt.task[b, k] = -1
        tt.since[b, k] = 0
        tt.started[b, k] = False
        tt.tried[b, k] = -1
        tt.probe[b, k] = -1
        for p in range(tt.infeasible.shape[2]):
            tt.infeasible[b, k, p] = 0
    tt.probe_t[b] = -1
    tt.cycles[b] = 0


@kernel
def allows(ms, st, ts, tt, b, crane, p):
    """The crane could take task ``p`` now (``TaskBook.allows``)."""
    c, t = ts.task_comp[p], ts.task_target[p]
    if not tt.static_ok[b, crane, p] or not st.target_ready[b, t]:
        return False
    for k in range(ms.n_cranes):
        q = tt.task[b, k]
        if q >= 0 and (ts.task_comp[q] == c or ts.task_target[q] == t):
            return False
    return claimable(ms, st, b, c)


@kernel
def _open_pairs(ms, st, ts, tt, sc, b):
    """``sc.open_pairs[p]``: task ``p``'s component and target are open
    (``TaskBook._open_pairs``)."""
    C = len(ms.length)
    comp_ok, target_ok, out = sc.comp_ok, sc.target_ok, sc.open_pairs
    for c in range(C):
        comp_ok[c] = claimable(ms, st, b, c)
        target_ok[c] = st.target_ready[b, c]
    for k in range(ms.n_cranes):
        q = tt.task[b, k]
        if q >= 0:
            comp_ok[ts.task_comp[q]] = False
            target_ok[ts.task_target[q]] = False
    for p in range(len(out)):
        out[p] = comp_ok[ts.task_comp[p]] and target_ok[ts.task_target[p]]


@kernel
def write_masks(ms, st, ts, tt, sc, masks, b):
    """(N, 1 + P) into ``masks[b]``: wait always; the allowed tasks of the idle cranes."""
    P = len(ts.task_comp)
    _open_pairs(ms, st, ts, tt, sc, b)
    open_ = sc.open_pairs
    for k in range(ms.n_cranes):
        masks[b, k, 0] = 1
        idle = tt.task[b, k] < 0
        for p in range(P):
            masks[b, k, 1 + p] = idle and open_[p] and tt.static_ok[b, k, p]


@kernel
def any_open(ms, st, ts, tt, sc, b):
    """Some idle crane has an allowed task."""
    P = len(ts.task_comp)
    idle = False
    for k in range(ms.n_cranes):
        idle |= tt.task[b, k] < 0
    if not idle:
        return False
    _open_pairs(ms, st, ts, tt, sc, b)
    open_ = sc.open_pairs
    for k in range(ms.n_cranes):
        if tt.task[b, k] < 0:
            for p in range(P):
                if open_[p] and tt.static_ok[b, k, p]:
                    return True
    return False


@inlined
def _take(tt, b, crane, p, T):
    tt.task[b, crane] = p
    tt.since[b, crane] = T
    tt.started[b, crane] = False


@kernel
def _try(ms, st, ts, tt, tb, sc, ss, b, crane, p):
    """Hand task ``p`` to the carrier: started, or held (no path yet)."""
    tt.tried[b, crane] = st.step_count[b]
    if try_start(ms, st, ts, tt, sc, ss, b, crane, ts.task_comp[p], ts.task_target[p]):
        tt.started[b, crane] = True
        tb.task_counts[b, crane, STARTED] += 1
    else:
        tb.task_counts[b, crane, HELD] += 1


@kernel
def choose(ms, st, ts, tt, tb, sc, ss, b, choices):
    """The idle cranes' choices (0 wait, 1 + p task p): the probed ones first, then the
    others in crane order; a task no longer allowed is refused (the crane waits)."""
    T = st.step_count[b]
    N = ms.n_cranes
    probing = tt.probe_t[b] == T
    if probing:
        for k in range(N):
            p = tt.probe[b, k]
            if p >= 0 and (tt.task[b, k] >= 0 or choices[k] != 1 + p):
                cancel(tt, b, k)
                tt.probe[b, k] = -1
        for k in range(N):
            p = tt.probe[b, k]
            if p >= 0:
                _take(tt, b, k, p, T)
                tt.started[b, k] = True
                tb.task_counts[b, k, STARTED] += 1
    for k in range(N):
        a = choices[k]
        if a == 0 or tt.task[b, k] >= 0:
            continue
        p = a - 1
        if not allows(ms, st, ts, tt, b, k, p):
            tb.task_counts[b, k, REFUSED] += 1
            continue
        _take(tt, b, k, p, T)
        _try(ms, st, ts, tt, tb, sc, ss, b, k, p)
    for k in range(N):
        tt.probe[b, k] = -1
    tt.probe_t[b] = -1


@kernel
def motion(ms, st, ts, tt, tb, sc, ss, b, joint):
    """The cranes' motion actions for the next simulated step into ``joint``: held tasks are
    retried first (``TaskBook.motion``)."""
    T = st.step_count[b]
    begin(ms, st, ts, tt, sc, ss, b, T)
    for k in range(ms.n_cranes):
        p = tt.task[b, k]
        if p < 0 or tt.started[b, k] or tt.tried[b, k] == T:
            continue
        if try_start(ms, st, ts, tt, sc, ss, b, k, ts.task_comp[p], ts.task_target[p]):
            tt.started[b, k] = True
            tb.task_counts[b, k, STARTED] += 1
    planned(ms, st, ts, tt, sc, ss, b, T, joint)


@kernel
def after_step(ms, st, ts, tt, tb, b):
    """Update the tasks after a simulated step; True when some busy crane became idle."""
    T = st.step_count[b]
    freed = False
    for k in range(ms.n_cranes):
        p = tt.task[b, k]
        if p < 0:
            continue
        if not tt.started[b, k]:
            if T - tt.since[b, k] >= ts.patience:
                tt.task[b, k] = -1
                freed = True
                tb.task_counts[b, k, DROPPED] += 1
            continue
        if st.held[b, k] >= 0 or st.assembling[b, k]:
            continue
        if st.status[b, ts.task_comp[p]] == ASSEMBLED:
            tt.task[b, k] = -1
            freed = True
            tb.task_counts[b, k, DONE] += 1
        else:  # the claim did not happen: hold the task and retry
            tt.started[b, k] = False
            tt.since[b, k] = T
    return freed


@kernel
def feasible(ms, st, ts, tt, sc, ss, b, crane, p):
    """Would task ``p`` start for ``crane`` now? On success the plan is kept for the crane
    until ``choose`` (``TaskBook.feasible``)."""
    T = st.step_count[b]
    if tt.probe_t[b] != T:
        for k in range(ms.n_cranes):
            tt.probe[b, k] = -1
        tt.probe_t[b] = T
    if tt.probe[b, crane] == p:
        return True
    if tt.infeasible[b, crane, p] == T + 1 or tt.task[b, crane] >= 0:
        return False
    if not allows(ms, st, ts, tt, b, crane, p):
        return False
    if tt.probe[b, crane] >= 0:
        cancel(tt, b, crane)
        tt.probe[b, crane] = -1
    if try_start(ms, st, ts, tt, sc, ss, b, crane, ts.task_comp[p], ts.task_target[p]):
        tt.probe[b, crane] = p
        return True
    tt.infeasible[b, crane, p] = T + 1
    return False


@kernel
def time_left(ms, st, ts, tt, b, crane):
    """``TaskBook.time_left``: estimated simulated steps until the crane is idle."""
    p = tt.task[b, crane]
    if p < 0:
        return 0
    if not tt.started[b, crane]:
        return tt.static_len[b, crane, p] + 1 + ms.assembly_steps
    return carrier_time_left(ms, st, tt, b, crane)
