"""The step kernel: one action per copy, all ``B`` copies in one call, autoresets included.

``step_batch`` is ``PaperAssemblyEnv.step`` for every copy (docs/paper-spec.md section 5,
"Order of work inside one step"): count the step; consume a pending pass-over, or lift the
current component if it is still initial and apply the move; on arrival assemble it; if no
component is current, let the pointer choose; then the reward, termination and truncation,
the event counts, the observation (only the plan columns whose cells changed) and the mask.
A copy whose episode ended is reset in the same call (``autoreset``) after its last
observation is kept in ``final_obs``.
"""

from __future__ import annotations

from multicrane.core.codes import N_MOVES, EventType
from multicrane.vector import paper_rules as rules
from multicrane.vector.compiled import kernel
from multicrane.vector.paper_reset import reset_copy

_LIFTED = int(EventType.LIFTED)
_BLOCKED = int(EventType.BLOCKED)
_LIFT_BLOCKED = int(EventType.LIFT_BLOCKED)
_ARRIVED = int(EventType.ARRIVED)
_ASSEMBLED = int(EventType.ASSEMBLED)
_PASS_OVER = int(EventType.PASS_OVER)
_ILLEGAL = int(EventType.ILLEGAL)
_ASSIGNED = int(EventType.ASSIGNED)


@kernel
def _act(site, st, buf, b, action):
    """The crane's part of the step; returns (progress made, plan columns touched)."""
    events = buf.event_counts
    if st.pass_over[b]:  # the action is ignored
        st.pass_over[b] = False
        events[b, _PASS_OVER] += 1
        return 1, 0
    comp = st.held[b]
    if comp < 0:
        events[b, _ILLEGAL] += 1
        return 0, 0
    touched = 0
    if st.status[b, comp] == rules.INITIAL:
        if not rules.fits(st, b, comp, st.pickup, comp):
            events[b, _LIFT_BLOCKED] += 1
            return 0, 0
        touched = rules.place(site, st, buf, b, comp, st.pickup, 0, touched)
        st.status[b, comp] = rules.IN_TRANSIT
        events[b, _LIFTED] += 1
        if rules.arrives(site, st, b, comp):
            events[b, _ARRIVED] += 1
            events[b, _ASSEMBLED] += 1
            return 1, touched
    if not rules.move_ok(site, st, b, comp, st.cells, action):
        events[b, _BLOCKED] += 1
        return 0, touched
    touched = rules.place(site, st, buf, b, comp, st.cells, site.move_delta[action], touched)
    st.moves[b, comp] += 1
    if rules.arrives(site, st, b, comp):
        events[b, _ARRIVED] += 1
        events[b, _ASSEMBLED] += 1
        return 1, touched
    return 0, touched


@kernel
def _reward(site, st, b, progress, complete):
    """docs/paper-spec.md section 5, item 6 (``multicrane.envs.reward.team_reward``)."""
    if complete:
        return site.completion
    if progress:
        return float(progress * st.n_assembled[b])
    comp = st.held[b]
    if comp >= 0 and st.moves[b, comp] > site.move_limit:
        return -site.over_limit_cost
    return -site.step_cost / (st.n_assembled[b] - site.n_prebuilt + 1)


@kernel
def step_copy(site, st, buf, b, action, mask_blocked):
    """One step of copy ``b``; returns True when its episode ended."""
    for e in range(buf.event_counts.shape[1]):
        buf.event_counts[b, e] = 0
    st.step_count[b] += 1
    progress, touched = _act(site, st, buf, b, action)
    if st.held[b] < 0 and not st.pass_over[b]:
        buf.event_counts[b, _ASSIGNED] += rules.assign(site, st, b)
    complete = st.n_assembled[b] == len(site.length)
    buf.rewards[b] = _reward(site, st, b, progress, complete)
    buf.terminated[b] = complete
    buf.truncated[b] = not complete and st.step_count[b] >= site.step_limit
    k = st.n_assembled[b] - site.n_prebuilt
    for i in range(touched):
        rules.refresh_column(site, st, buf.obs, b, buf.touched[i], k)
    if progress and buf.event_counts[b, _ASSEMBLED]:
        rules.rescale_arrived(site, st, buf.obs, b, k)
    if mask_blocked:
        rules.write_mask(site, st, buf.masks, b)
    buf.component_index[b] = st.held[b]
    return complete or buf.truncated[b]


@kernel
def step_batch(site, st, buf, actions, mask_blocked, autoreset):
    """Step every copy with its action; returns (first copy with an action outside 0..5,
    first copy whose reset found no start), each -1 when none. Nothing is stepped when an
    action is out of range."""
    n = len(actions)
    for b in range(n):
        if actions[b] < 0 or actions[b] >= N_MOVES:
            return b, -1
    for b in range(n):
        if step_copy(site, st, buf, b, actions[b], mask_blocked) and autoreset:
            for i in range(buf.obs.shape[1]):
                buf.final_obs[b, i] = buf.obs[b, i]
            if not reset_copy(site, st, buf, b, mask_blocked):
                return -1, b
    return -1, -1
