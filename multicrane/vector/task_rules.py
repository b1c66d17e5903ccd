"""The prioritized rule at the task level, compiled: each copy's choices in one call.

``propose_batch`` is ``multicrane.tasks.priority_rule.propose`` (what
``policies.task_planners.TaskPrioritized`` sends) for every copy: the ready (component,
target) pairs in the episode's ranking (``priority_rule.rank_pairs``, kept per copy in
``ranking``), each given to the first idle crane that may take it, kept when the carrier's
search succeeds (``task_book.feasible``: the plan stays with the crane for the step's
``choose``), at most ``max_searches`` searches a round. The answer is the step's actions
(``1 + p``, or 0), so ``env.step(env.propose())`` plays the rule.
"""

from __future__ import annotations

from multicrane.vector import motion_rules as rules
from multicrane.vector.compiled import kernel
from multicrane.vector.task_book import _open_pairs, feasible
from multicrane.vector.task_carrier import begin
from multicrane.vector.task_plans import slot_of


@kernel
def _propose_copy(ms, st, ts, tt, sc, ss, b, rank_comp, rank_target, n_ranked, max_searches,
                  out, flags):  # fmt: skip
    """Copy ``b``'s actions into ``out[b]`` (module doc); ``flags``: scratch, (4, C) bools."""
    N, C = ms.n_cranes, len(ms.length)
    for k in range(N):
        out[b, k] = 0
    any_idle = False
    for k in range(N):
        any_idle |= tt.task[b, k] < 0
    if not any_idle:
        return
    begin(ms, st, ts, tt, sc, ss, b, st.step_count[b])  # (its scratch: sc.cranes too)
    if not tt.may_start[b]:
        return
    n_idle = 0
    idle = sc.cranes  # the idle cranes, in crane order (taken ones leave)
    for k in range(N):
        if tt.task[b, k] < 0:
            idle[n_idle] = k
            n_idle += 1
    _open_pairs(ms, st, ts, tt, sc, b)  # ``book.allowed()``, as the round began
    chosen, open_target, used, used_t = flags[0], flags[1], flags[2], flags[3]
    for c in range(C):
        chosen[c] = rules.claimable(ms, st, b, c) and slot_of(tt, b, c) < 0
        open_target[c] = st.target_ready[b, c]
        used[c] = False
        used_t[c] = False
    for s in range(tt.slot_comp.shape[1]):
        if tt.slot_comp[b, s] >= 0:
            open_target[tt.slot_target[b, s]] = False
    for i in range(n_ranked[b]):
        comp, t = rank_comp[b, i], rank_target[b, i]
        if not chosen[comp] or not open_target[t]:
            continue
        if n_idle == 0 or tt.round_searches[b] >= max_searches:
            break
        if used[comp] or used_t[t]:
            continue
        p = ts.task_of[comp, t]
        j = 0
        while j < n_idle and not (sc.open_pairs[p] and tt.static_ok[b, idle[j], p]):
            j += 1
        if j == n_idle:
            continue
        crane = idle[j]
        if feasible(ms, st, ts, tt, sc, ss, b, crane, p):
            out[b, crane] = 1 + p
            for u in range(j, n_idle - 1):
                idle[u] = idle[u + 1]
            n_idle -= 1
            used[comp] = True
            used_t[t] = True


@kernel
def propose_batch(ms, st, ts, tt, sc, ss, rank_comp, rank_target, n_ranked, max_searches, out,
                  flags):  # fmt: skip
    """``_propose_copy`` of every copy into ``out`` ((B, N) int64)."""
    for b in range(out.shape[0]):
        _propose_copy(ms, st, ts, tt, sc, ss, b, rank_comp, rank_target, n_ranked,
                      max_searches, out, flags)  # fmt: skip
