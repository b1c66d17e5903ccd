"""The motion mode's step and reset kernels: every copy in one call, autoresets included.

``step_batch`` is ``MultiCraneEnv.step`` (motion mode, ``multicrane.envs.motion_mode``) for
every copy: count the step, draw the crane order (``rng.permutation(N)``, none for one crane),
let each crane act in that order, then the reward of ``multicrane.envs.reward`` (team and
per-crane terms), termination and truncation, the observations (only what changed) and the
masks; with site events the schedule's changes come after the actions
(``motion_events.apply_events``). A copy whose episode ended is reset in the same call
(``autoreset``) after its last observations are kept in ``final_obs``. ``reset_copy`` draws
the start with the paper mode's kernel (``draw_start``, the same draws as
``multicrane.sim.start.draw_start``) and builds the state as ``SiteState.at_start`` and
``Simulator.reset`` do. With site events a reset stops after the start
(``buf.scheduling[b]``): the schedule is drawn next, from the copy's generator, by numpy
itself (``multicrane.vector.event_schedules``), and ``finish_resets`` completes them.
"""

from __future__ import annotations

from multicrane.vector import motion_rules as rules
from multicrane.vector.compiled import inlined, kernel
from multicrane.vector.motion_events import apply_events, start_events
from multicrane.vector.motion_observe import observe_reset, observe_step
from multicrane.vector.motion_prefetch import prefetch_copy
from multicrane.vector.paper_reset import draw_start, lay_out
from multicrane.vector.pcg64 import permutation


@inlined
def team_reward(site, st, buf, b, complete):
    """``motion_mode.physical_step``'s reward: the team reward, and each crane's term."""
    N = site.n_cranes
    terms = buf.terms
    if site.makespan:
        r = -1.0 + (site.completion if complete else 0.0)
        for k in range(N):
            terms[b, k] = r / N
        return r
    n_progress = buf.n_progress[0]
    n_over = 0
    for k in range(N):
        comp = st.held[b, k]
        if comp >= 0 and st.moves[b, comp] > site.move_limit:
            n_over += 1
    if complete:
        r = site.completion
    elif n_progress:
        r = float(n_progress * st.n_assembled[b])
    elif n_over:
        r = -site.over_limit_cost
    else:
        r = -site.step_cost / (st.n_assembled[b] - site.n_prebuilt + 1)
    for k in range(N):
        terms[b, k] = 0.0 if n_progress or n_over else r / N
    if n_progress:
        for i in range(n_progress):
            terms[b, buf.progress_by[i]] += r / n_progress
    elif n_over:
        for k in range(N):
            comp = st.held[b, k]
            if comp >= 0 and st.moves[b, comp] > site.move_limit:
                terms[b, k] += r / n_over
    return r


@inlined
def act_in_order(site, st, buf, b, actions):
    """Count the step and let each crane of copy ``b`` act (``actions``: one per crane) in
    an order drawn from the copy's generator (``rng.permutation(N)``; none for one crane)."""
    N = site.n_cranes
    st.step_count[b] += 1
    if N > 1:
        permutation(st.rng, b, buf.order, N)
    else:
        buf.order[0] = 0
    buf.n_progress[0] = 0
    buf.ready_changed[0] = False
    for i in range(N):
        crane = buf.order[i]
        rules.act(site, st, buf, b, crane, actions[crane])


@inlined
def step_copy(site, st, buf, b, actions):
    """One joint step of copy ``b``; returns True when its episode ended."""
    N = site.n_cranes
    for k in range(N):
        for e in range(buf.event_counts.shape[2]):
            buf.event_counts[b, k, e] = 0
    act_in_order(site, st, buf, b, actions[b])
    if site.has_events:
        apply_events(site, st, buf, b)
    complete = st.n_assembled[b] == len(site.length)
    r = team_reward(site, st, buf, b, complete)
    count = st.step_count[b]
    truncated = not complete and (
        count >= site.step_limit or (site.cycle_limit > 0 and count >= site.cycle_limit)
    )
    for k in range(N):
        buf.rewards[b, k] = buf.terms[b, k] if site.split else r
        buf.terminated[b, k] = complete
        buf.truncated[b, k] = truncated
    observe_step(site, st, buf, b)
    rules.write_masks(site, st, buf.masks, b)
    return complete or truncated


@kernel
def _lay_out(site, st, buf, b):
    """The components at the start drawn in ``buf.chosen`` (``paper_reset.lay_out``), none
    held, and each crane's reach of the pick-up poses."""
    lay_out(site, st, buf, b)
    C, L = site.target_cells.shape
    for i in range(C):
        st.holder[b, i] = -1
        for k in range(site.n_cranes):
            inside = True
            for u in range(L):
                j = st.pickup[b, i, u]
                if j >= 0 and not site.zone[k, j]:
                    inside = False
            st.pickup_in_zone[b, k, i] = inside


@kernel
def _finish_reset(site, st, buf, b, count):
    """The new episode's time 0 (with a schedule written, when there are site events; its
    site events counted when ``count``), readiness, observations and masks."""
    if site.has_events:
        start_events(site, st, buf, b, count)
    rules.refresh_ready(site, st, buf, b)
    observe_reset(site, st, buf, b)
    rules.write_masks(site, st, buf.masks, b)


@kernel
def start_copy(site, st, buf, b):
    """Copy ``b`` at the start of a new episode drawn from its generator (no crane holds or
    assembles anything, nothing assembled but the pre-built); False when no start is found."""
    if not draw_start(site, st, buf, b):
        return False
    _lay_out(site, st, buf, b)
    for k in range(site.n_cranes):
        st.held[b, k] = -1
        st.assembling[b, k] = 0
    st.n_assembled[b] = site.n_prebuilt
    st.step_count[b] = 0
    return True


@kernel
def reset_copy(site, st, buf, b):
    """Start a new episode in copy ``b`` from its generator (with site events: up to the
    start, then ``buf.scheduling[b]``); False when no start is found."""
    if not start_copy(site, st, buf, b):
        return False
    if site.has_events:
        buf.scheduling[b] = True
    else:
        _finish_reset(site, st, buf, b, False)
    return True


@kernel
def finish_resets(site, st, buf, count):
    """Complete the resets of the copies in ``buf.scheduling`` once their schedules are
    written (their time-0 site events counted when ``count``: a reset, not an autoreset)."""
    for b in range(len(buf.scheduling)):
        if buf.scheduling[b]:
            buf.scheduling[b] = False
            _finish_reset(site, st, buf, b, count)


@kernel
def reset_copies(site, st, buf, which):
    """Reset every copy with ``which[b]``; returns the first copy with no start, else -1."""
    for b in range(len(which)):
        if which[b] and not reset_copy(site, st, buf, b):
            return b
    return -1


@inlined
def first_out_of_range(actions, n_cranes, A):
    """(copy, crane) of the first action outside ``0..A-1``, (-1, -1) when none."""
    for b in range(actions.shape[0]):
        for k in range(n_cranes):
            if actions[b, k] < 0 or actions[b, k] >= A:
                return b, k
    return -1, -1


@inlined
def keep_final_obs(buf, b):
    """Copy ``b``'s last observations into ``buf.final_obs`` (its episode just ended)."""
    for k in range(buf.obs.shape[1]):
        for i in range(buf.obs.shape[2]):
            buf.final_obs[b, k, i] = buf.obs[b, k, i]


@kernel
def step_batch(site, st, buf, actions, autoreset):
    """Step every copy with its row of ``actions`` ((B, N) int64); returns (copy, crane) of
    the first action outside ``0..A-1`` (nothing is stepped then), and the first copy whose
    reset found no start; -1 where none. The next copy's lines are prefetched while a copy
    steps (``motion_prefetch``)."""
    n = actions.shape[0]
    bad_copy, bad_crane = first_out_of_range(actions, site.n_cranes, buf.masks.shape[2])
    if bad_copy >= 0:
        return bad_copy, bad_crane, -1
    for b in range(n):
        if b + 1 < n:
            prefetch_copy(site, st, buf, b + 1)
        if step_copy(site, st, buf, b, actions) and autoreset:
            keep_final_obs(buf, b)
            if not reset_copy(site, st, buf, b):
                return -1, -1, b
    return -1, -1, -1
