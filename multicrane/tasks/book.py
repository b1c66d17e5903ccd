"""Task-level decisions: the task list, the task masks, and each crane's task until it is done.

A *task* is a (component, compatible target) pair of the scenario; ``TaskList``
(``multicrane.tasks.task_list``) numbers them component-major (component 0's targets first,
each in target order). The task-level environment (``MultiCraneEnv(decisions="task")``)
gives each crane the actions ``0`` (wait; for a busy crane: continue) and ``1 + p`` (take
task ``p``).

**Masks** (``TaskBook.masks``). A busy crane may only continue (``0``). For an idle crane task
``p = (c, t)`` is allowed iff component ``c`` is claimable now (initial, not claimed, its
pick-up pose free; a beam or panel needs a ready target) and is not another crane's task, target
``t`` is free and ready (its supports assembled) and not another crane's task's target, and
the crane can carry ``c`` to ``t``: its reach holds the pick-up pose and the target and a
path exists through the static site inside its reach (``static_ok``, breadth-first
searches done once per start pose and cached). The mask does not run the space-time search.
With site events (``multicrane.sim.events``) a crane that is down is allowed no task, a component
not yet delivered is not claimable and a target with a closed cell is not ready, so neither
appears in an allowed task; a busy crane that breaks down keeps its task (it waits).

**Hold, retry, drop.** A chosen task is handed to the carrier (``multicrane.tasks.carrier_events``:
it replans on site events). If its space-time search fails now, the crane *holds* the task:
it is busy, nothing is lifted, the component and target are kept for it, and the search is
tried again before every simulated step; when ``patience`` simulated steps have passed since
it was chosen without a path, the task is dropped after that step and the crane is idle again
(a ``TASK_DROPPED`` task event; the environment's step returns then, as for any crane
becoming idle).

Task events are ``(name, crane, task)`` tuples: ``TASK_STARTED`` (the carrier has a path:
the claim is the next step), ``TASK_HELD`` (chosen, no path yet), ``TASK_DROPPED``,
``TASK_REFUSED`` (the choice was not allowed, e.g. an earlier crane took the component or
target this round: treated as wait) and ``TASK_DONE`` (the component is assembled).
"""

from __future__ import annotations

import copy
from contextlib import contextmanager

import numpy as np

from multicrane.core.codes import Status
from multicrane.sim.shortest_paths import UNREACHABLE
from multicrane.sim.simulator import NOBODY, Simulator
from multicrane.tasks.carrier_events import EventCarrier
from multicrane.tasks.static_paths import StaticPaths
from multicrane.tasks.task_list import TaskList

_INITIAL, _IN_TRANSIT, _ARRIVED, _ASSEMBLED = (int(s) for s in Status)

TaskEvent = tuple[str, int, int]  # (name, crane, task)


class TaskBook:
    """The cranes' tasks in one episode: masks, choices, hold/retry/drop, completion."""

    def __init__(self, sim: Simulator, patience: int = 20, slack: int = 40,
                 max_expansions: int = 20000):  # fmt: skip
        if patience < 1:
            raise ValueError(f"task_patience must be at least 1, got {patience!r}")
        self.sim = sim
        self.patience = int(patience)
        self.tasks = TaskList(sim)
        self.carrier = EventCarrier(sim, slack, max_expansions)  # replans on site events
        self.static = StaticPaths(sim, self.carrier.goals)
        self.n_actions = 1 + len(self.tasks)

    def reset(self) -> None:
        """Start an episode (after ``sim.reset``): no tasks; static reach of every task."""
        sim = self.sim
        n = sim.n_cranes
        self.carrier.reset()
        self.task: list[int] = [NOBODY] * n  # crane -> task index, NOBODY when idle
        self.since = [0] * n  # when the task was chosen (for the patience)
        self.started = [False] * n  # the carrier has it (claimed or carrying)
        self._tried = [-1] * n  # when the held task's search last ran
        self._probe: dict[int, int] = {}  # crane -> task started by task_feasible this round
        self._probe_t: int | None = None
        self._infeasible: set[tuple[int, int]] = set()
        self._open_kept: tuple | None = None  # (key, claimable, open pairs): _open_pairs
        self._any_kept: tuple | None = None  # (open pairs, idle cranes, answer): any_open
        self.static_len = self._static_lengths()
        self.static_ok = self.static_len != UNREACHABLE

    def _static_lengths(self) -> np.ndarray:
        """(N, P): ``static_lengths`` of this episode's pick-up poses."""
        sim = self.sim
        return static_lengths(sim.site, self.static, self.tasks, sim.state.pickup, sim.n_cranes)

    # -- queries ---------------------------------------------------------------------------

    def busy(self, crane: int) -> bool:
        return self.task[crane] != NOBODY

    def idle_cranes(self) -> list[int]:
        return [k for k in range(self.sim.n_cranes) if self.task[k] == NOBODY]

    def _open(self) -> tuple[np.ndarray, np.ndarray]:
        """Per component: claimable and not any crane's task; per target: free, ready and
        not any crane's task's target."""
        sim = self.sim
        C = sim.site.n_components
        comp_ok = np.zeros(C, dtype=bool)
        comp_ok[sim.claimable_components()] = True
        target_ok = np.array(sim.target_ready, dtype=bool)
        for p in self.task:
            if p != NOBODY:
                comp_ok[self.tasks.comp[p]] = False
                target_ok[self.tasks.target[p]] = False
        return comp_ok, target_ok

    def _open_pairs(self) -> np.ndarray:
        """(P,) bool, read-only: the task's component and target are open (``_open``); kept
        while the claimable components, the targets' readiness and the tasks stay as they
        were (a decision round asks several times, its simulated steps once each)."""
        sim = self.sim
        claimable = sim.claimable_components()
        key = (sim.targets_version, tuple(self.task))
        kept = self._open_kept
        if kept is not None and kept[0] == key and kept[1] == claimable:
            return kept[2]
        comp_ok, target_ok = self._open()
        ok = comp_ok[self.tasks.comp] & target_ok[self.tasks.target]
        ok.flags.writeable = False
        self._open_kept = (key, list(claimable), ok)
        return ok

    def allowed(self, cranes: list[int] | None = None) -> np.ndarray:
        """(N, P) bool: the tasks each crane could take now were it idle; the rows of
        ``cranes`` only, in that order, when given."""
        if cranes is None:
            cranes = list(range(self.sim.n_cranes))
        ok = self.static_ok[cranes] & self._open_pairs()
        if self.sim.schedule is not None:
            ok[[not self.sim.crane_up(k) for k in cranes]] = False
        return ok

    def allows(self, crane: int, p: int) -> bool:
        """``allowed()[crane, p]``, without building the table."""
        sim = self.sim
        c, t = self.tasks.pairs[p]
        if not self.static_ok[crane, p] or not sim.target_ready[t]:
            return False
        if sim.schedule is not None and not sim.crane_up(crane):
            return False
        for q in self.task:
            if q != NOBODY and (self.tasks.comp[q] == c or self.tasks.target[q] == t):
                return False
        return c in sim.claimable_components()

    def masks(self) -> np.ndarray:
        """(N, 1 + P) int8: wait always; tasks only for idle cranes (see the module doc)."""
        n = self.sim.n_cranes
        masks = np.zeros((n, self.n_actions), dtype=np.int8)
        masks[:, 0] = 1
        idle = self.idle_cranes()
        if idle:
            masks[idle, 1:] = self.allowed(idle)
        return masks

    def any_open(self) -> bool:
        """Some idle crane has an allowed task (``allowed``, for the idle rows only)."""
        idle = self.idle_cranes()
        if self.sim.schedule is not None:
            idle = [k for k in idle if self.sim.crane_up(k)]
        if not idle:
            return False
        open_, idle = self._open_pairs(), tuple(idle)
        kept = self._any_kept
        if kept is None or kept[0] is not open_ or kept[1] != idle:
            answer = bool((self.static_ok[list(idle)] & open_).any())
            kept = self._any_kept = (open_, idle, answer)
        return kept[2]

    def time_left(self, crane: int) -> int:
        """Estimated simulated steps until the crane is idle (0 when idle)."""
        if self.task[crane] == NOBODY:
            return 0
        if not self.started[crane]:
            p = self.task[crane]
            return int(self.static_len[crane, p]) + 1 + self.sim.scenario.assembly_steps
        return self.carrier.time_left(crane)

    # -- planners' probe -------------------------------------------------------------------

    def feasible(self, crane: int, p: int) -> bool:
        """Would task ``p`` start for ``crane`` now (its space-time search succeeds)? On
        success the plan is kept for the crane until the next ``choose``, which uses it if
        the crane chooses ``p`` and drops it otherwise."""
        T = self.sim.state.step_count
        if self._probe_t != T:
            self._probe, self._infeasible, self._probe_t = {}, set(), T
        if self._probe.get(crane) == p:
            return True
        if (crane, p) in self._infeasible or self.task[crane] != NOBODY:
            return False
        if not self.allows(crane, p):
            return False
        if crane in self._probe:
            self.carrier.cancel(crane)
            del self._probe[crane]
        c, t = self.tasks.pairs[p]
        if self.carrier.try_start(crane, int(c), int(t)):
            self._probe[crane] = p
            return True
        self._infeasible.add((crane, p))
        return False

    @contextmanager
    def trial(self):
        """A book to probe with (``feasible``) that leaves this one as it was: itself, its
        probes cancelled and its round's search count, probes and counters restored on exit;
        or, when some planner already probed this round, a copy with those probes cancelled
        (the round as it began; a probe made here could replace one of theirs)."""
        sim, carrier = self.sim, self.carrier
        T = sim.state.step_count
        carrier.begin(T)  # the round's own work (replans after events), kept and counted
        if self._probe_t == T and self._probe:
            shared = (sim, self.tasks, self.static, carrier.shapes, carrier.memo)  # exact answers
            scratch = copy.deepcopy(self, {id(x): x for x in shared if x is not None})
            for crane in scratch._probe:
                scratch.carrier.cancel(crane)
            scratch._probe_t, scratch.carrier.round_searches = None, 0  # (try_start counts)
            yield scratch
            return
        saved = (self._probe_t, self._probe, self._infeasible, carrier.round_searches,
                 dict(carrier.stats))  # fmt: skip
        try:
            yield self
        finally:
            if self._probe_t == T:
                for crane in self._probe:
                    carrier.cancel(crane)
            self._probe_t, self._probe, self._infeasible = saved[:3]
            carrier.round_searches = saved[3]
            carrier.stats.clear()
            carrier.stats.update(saved[4])

    # -- choices and steps -----------------------------------------------------------------

    def choose(self, choices: list[int]) -> list[TaskEvent]:
        """Idle cranes' choices (``0`` wait, ``1 + p`` task ``p``): first those that
        ``feasible`` already started, then the others in crane order; a task no longer
        allowed (its component or target taken this round) is refused: the crane waits."""
        T = self.sim.state.step_count
        probes = self._probe if self._probe_t == T else {}
        for k, p in list(probes.items()):
            if self.task[k] != NOBODY or choices[k] != 1 + p:
                self.carrier.cancel(k)
                del probes[k]
        events: list[TaskEvent] = []
        for k, p in sorted(probes.items()):  # already started by the probe: taken first
            self._take(k, p, T)
            self.started[k] = True
            events.append(("TASK_STARTED", k, p))
        for k, a in enumerate(choices):
            if a == 0 or self.task[k] != NOBODY:
                continue
            p = a - 1
            if not self.allows(k, p):
                events.append(("TASK_REFUSED", k, p))
                continue
            self._take(k, p, T)
            events.append(self._try(k, p))
        self._probe, self._probe_t = {}, None
        return events

    def _take(self, crane: int, p: int, T: int) -> None:
        self.task[crane] = p
        self.since[crane] = T
        self.started[crane] = False

    def _try(self, crane: int, p: int) -> TaskEvent:
        self._tried[crane] = self.sim.state.step_count
        c, t = self.tasks.pairs[p]
        if self.carrier.try_start(crane, int(c), int(t)):
            self.started[crane] = True
            return ("TASK_STARTED", crane, p)
        return ("TASK_HELD", crane, p)

    def motion(self, events: list[TaskEvent]) -> list[int]:
        """The cranes' motion actions for the next simulated step: held tasks are retried
        (or dropped after ``patience`` steps), then the carrier's plans give the actions."""
        T = self.sim.state.step_count
        self.carrier.begin(T)
        for k in range(self.sim.n_cranes):
            p = self.task[k]
            if p == NOBODY or self.started[k] or self._tried[k] == T:
                continue
            c, t = self.tasks.pairs[p]
            if self.carrier.try_start(k, int(c), int(t)):
                self.started[k] = True
                events.append(("TASK_STARTED", k, p))
        if self.sim.schedule is None:
            return self.carrier.actions(T)
        # Events can refuse a planned action (a crane down, a closed cell): it becomes wait
        # and the carrier replans (see multicrane.tasks.carrier).
        return self.carrier.actions(T, self.sim.action_masks())

    def after_step(self, events: list[TaskEvent]) -> bool:
        """Update the tasks after a simulated step; True when some busy crane became idle."""
        st = self.sim.state
        freed = False
        for k in range(self.sim.n_cranes):
            p = self.task[k]
            if p == NOBODY:
                continue
            if not self.started[k]:
                if st.step_count - self.since[k] >= self.patience:
                    self.task[k] = NOBODY
                    freed = True
                    events.append(("TASK_DROPPED", k, p))
                continue
            if st.held[k] != NOBODY or st.assembling[k]:
                continue
            comp = int(self.tasks.comp[p])
            if st.status[comp] == _ASSEMBLED:
                self.task[k] = NOBODY
                freed = True
                events.append(("TASK_DONE", k, p))
            else:  # the claim did not happen: hold the task and retry
                self.started[k] = False
                self.since[k] = st.step_count
        return freed


def static_lengths(site, static: StaticPaths, tasks: TaskList, pickup, n_cranes: int) -> np.ndarray:
    """(N, P): each crane's static path length of each task from the pick-up poses
    ``pickup`` (``UNREACHABLE``: none, or the pick-up pose or the target out of the crane's
    reach); without reach zones one row serves every crane."""
    pairs = tasks.pairs
    if site.reach is None:
        row = np.empty(len(pairs), dtype=np.int64)
        for c, (ids, targets) in tasks.by_component().items():
            row[ids] = static.lengths(pickup[c], targets, -1)
        return np.repeat(row[None, :], n_cranes, axis=0)
    out = np.full((n_cranes, len(pairs)), UNREACHABLE, dtype=np.int64)
    for p, (c, t) in enumerate(pairs):
        for k in range(n_cranes):
            if site.reaches(k, pickup[c]) and site.reaches(k, site.target_cells[t]):
                out[k, p] = static.length(pickup[c], t, k)
    return out
