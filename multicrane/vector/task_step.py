"""The task level's round, reset and observation kernels: every copy in one call.

``step_copy`` is ``MultiCraneEnv.step`` with ``decisions="task"`` (``multicrane.envs.task_mode``)
for one copy: the choices (``task_book.choose``), then simulated steps with the carrier's
motion actions, each the motion mode's physical step (the crane order drawn from the copy's
generator, ``motion_rules.act`` per crane, ``motion_step.team_reward``), until a busy crane
becomes idle, an idle crane has an allowed task, or the episode ends; the rewards and counts
add up over the steps. ``observe_copy`` writes the task observation
(``multicrane.envs.task_observation``: the components table by its own compiled kernel, the
cranes table, each crane's tasks table with its "allowed" column) and the masks. A reset
starts in ``reset_start`` (the start drawn as the one-site env draws it) and ends, once the
episode's static path lengths are written (``multicrane.vector.task_vector_env``, through the
task book's own ``StaticPaths``), in ``observe_copies``.
"""

from __future__ import annotations

from multicrane.envs.task_observation_kernel import component_rows_kernel
from multicrane.vector import motion_rules as rules
from multicrane.vector.compiled import kernel
from multicrane.vector.motion_step import (
    act_in_order,
    first_out_of_range,
    keep_final_obs,
    start_copy,
    team_reward,
)
from multicrane.vector.task_book import (
    after_step,
    any_open,
    choose,
    motion,
    reset_book,
    time_left,
    write_masks,
)

N_COMPONENT_FEATURES, N_CRANE_FEATURES, N_TASK_FEATURES = 21, 10, 9


@kernel
def _component_rows(ms, st, ts, tt, sc, b):
    """The ``components`` table (C, 21 + N) into ``sc.table``, by ``component_rows_kernel``."""
    C, N = len(ms.length), ms.n_cranes
    comp = sc.table
    comp[:] = 0.0
    n_claimable = 0
    for c in range(C):
        sc.first[c] = st.cells[b, c, 0]
        sc.last[c] = st.cells[b, c, ms.length[c] - 1]
        if rules.claimable(ms, st, b, c):
            sc.claimable[n_claimable] = c
            n_claimable += 1
        sc.free_target[c] = st.filled_by[b, c] < 0
    n_taken = 0
    for k in range(N):
        if tt.task[b, k] >= 0:
            sc.taken[n_taken] = ts.task_comp[tt.task[b, k]]
            n_taken += 1
    component_rows_kernel(
        comp, st.status[b], sc.first, sc.last, ts.cell_xyz, ts.beam, ts.target_nodes,
        st.target_ready[b], sc.claimable[:n_claimable], sc.taken[:n_taken], sc.free_target,
        ts.task_comp, ts.task_target, tt.pair_len[b], tt.reach_can[b], ts.D, False,
        sc.free_target, sc.best,
    )  # fmt: skip


@kernel
def observe_copy(ms, st, ts, tt, tb, sc, b):
    """Every crane's task observation and the masks of copy ``b``."""
    N, P, C = ms.n_cranes, len(ts.task_comp), len(ms.length)
    write_masks(ms, st, ts, tt, sc, tb.masks, b)
    _component_rows(ms, st, ts, tt, sc, b)
    cranes = sc.crane_rows
    cranes[:] = 0.0
    for k in range(N):
        cranes[k, 1] = tt.task[b, k] >= 0
        cranes[k, 2] = min(time_left(ms, st, ts, tt, b, k) / ts.T_norm, 1.0)
        held = st.held[b, k]
        if held >= 0:
            cranes[k, 3] = 1.0
            for i in range(3):
                cranes[k, 4 + i] = ts.cell_xyz[st.cells[b, held, 0], i]
        for i in range(3):
            cranes[k, 7 + i] = ts.reach_row[k, i]
    width = N_COMPONENT_FEATURES + N
    at_cranes = C * width
    at_tasks = at_cranes + N * N_CRANE_FEATURES
    for k in range(N):
        row = tb.obs[b, k]
        for c in range(C):
            for i in range(width):
                row[c * width + i] = sc.table[c, i]
        for j in range(N):
            for i in range(N_CRANE_FEATURES):
                row[at_cranes + j * N_CRANE_FEATURES + i] = cranes[j, i]
        row[at_cranes + k * N_CRANE_FEATURES] = 1.0  # self
        for i in range(P * N_TASK_FEATURES):
            row[at_tasks + i] = tt.episode_tasks[b, k, i]
        if tt.task[b, k] < 0:
            for p in range(P):
                row[at_tasks + p * N_TASK_FEATURES + 8] = tb.masks[b, k, 1 + p]


@kernel
def _physical_step(ms, st, mbuf, b, joint):
    """One simulated step with one motion action per crane (``motion_step.act_in_order``);
    the team reward (each crane's share in ``mbuf.terms``) and whether the building is
    complete."""
    act_in_order(ms, st, mbuf, b, joint)
    complete = st.n_assembled[b] == len(ms.length)
    return team_reward(ms, st, mbuf, b, complete), complete


@kernel
def step_copy(ms, st, mbuf, ts, tt, tb, sc, ss, b, choices):
    """One decision round of copy ``b`` (module doc); True when its episode ended."""
    N = ms.n_cranes
    for k in range(N):
        for e in range(mbuf.event_counts.shape[2]):
            mbuf.event_counts[b, k, e] = 0
        for e in range(tb.task_counts.shape[2]):
            tb.task_counts[b, k, e] = 0
        tb.terms[b, k] = 0.0
    choose(ms, st, ts, tt, tb, sc, ss, b, choices)
    joint = sc.joint
    total = 0.0
    elapsed = busy = 0
    while True:
        motion(ms, st, ts, tt, tb, sc, ss, b, joint)
        r, complete = _physical_step(ms, st, mbuf, b, joint)
        elapsed += 1
        for k in range(N):
            busy += st.held[b, k] >= 0
        busy += mbuf.n_progress[0]
        total += r
        for k in range(N):
            tb.terms[b, k] += mbuf.terms[b, k]
        freed = after_step(ms, st, ts, tt, tb, b)
        truncated = not complete and st.step_count[b] >= ms.step_limit
        if complete or truncated or freed or any_open(ms, st, ts, tt, sc, b):
            break
    tt.cycles[b] += 1
    count = st.step_count[b]
    truncated = not complete and (
        count >= ms.step_limit or (ts.cycle_limit > 0 and tt.cycles[b] >= ts.cycle_limit)
    )
    for k in range(N):
        tb.rewards[b, k] = tb.terms[b, k] if ms.split else total
        tb.terminated[b, k] = complete
        tb.truncated[b, k] = truncated
    tb.elapsed[b] = elapsed
    tb.crane_steps[b] = busy
    observe_copy(ms, st, ts, tt, tb, sc, b)
    return complete or truncated


@kernel
def reset_start(ms, st, mbuf, tt, b):
    """A new episode in copy ``b`` up to its static path lengths: the start drawn from its
    generator, no tasks, no plans; False when no start is found."""
    if not start_copy(ms, st, mbuf, b):
        return False
    rules.refresh_ready(ms, st, mbuf, b)
    reset_book(tt, b)
    return True


@kernel
def reset_starts(ms, st, mbuf, tt, which):
    """``reset_start`` of every copy with ``which[b]``; the first copy with no start, else -1."""
    for b in range(len(which)):
        if which[b] and not reset_start(ms, st, mbuf, tt, b):
            return b
    return -1


@kernel
def observe_copies(ms, st, ts, tt, tb, sc, which):
    """``observe_copy`` of every copy with ``which[b]`` (after its reset)."""
    for b in range(len(which)):
        if which[b]:
            observe_copy(ms, st, ts, tt, tb, sc, b)


@kernel
def step_batch(ms, st, mbuf, ts, tt, tb, sc, ss, choices):
    """One round of every copy with its row of ``choices`` ((B, N) int64); a copy whose
    episode ended keeps its last observation in ``final_obs``, is reset up to its static
    paths and flagged in ``tb.ended``. Returns (copy, crane) of the first choice outside
    ``0..P`` (nothing is stepped then), and the first copy whose reset found no start; -1
    where none."""
    bad_copy, bad_crane = first_out_of_range(choices, ms.n_cranes, tb.masks.shape[2])
    if bad_copy >= 0:
        return bad_copy, bad_crane, -1
    for b in range(choices.shape[0]):
        tb.ended[b] = False
        if step_copy(ms, st, mbuf, ts, tt, tb, sc, ss, b, choices[b]):
            keep_final_obs(tb, b)
            tb.ended[b] = True
            if not reset_start(ms, st, mbuf, tt, b):
                return -1, -1, b
    return -1, -1, -1
