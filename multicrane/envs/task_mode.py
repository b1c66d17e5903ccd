"""The task decision mode of ``MultiCraneEnv(decisions="task")``: choices in, simulated steps out.

One ``step`` takes each idle crane's choice (``0`` wait, ``1 + p`` task ``p``; a busy crane
may only send ``0``: continue), starts the chosen tasks in crane order (``multicrane.tasks.book``),
then advances the simulator one physical step at a time with the carrier's motion actions,
through the motion mode's physical step (``multicrane.envs.motion_mode.physical_step``:
the same ``Simulator.step``, the crane order drawn from the episode's generator), until
(a) a crane that was busy becomes idle, (b) after a step some idle crane has an allowed
task, or (c) the building is complete or the step limit truncates. At least one simulated
step passes, so "wait" waits one step at least.

The simulator's step count is the clock: the step limit, the makespan and the metrics count
simulated steps. The reward is the sum over the elapsed steps. The infos
(``multicrane.envs.infos``) count the crane's physical events of every elapsed step and its
task events (``multicrane.tasks.book``), and give ``elapsed`` (simulated steps of this env step)
and ``crane_steps`` (crane x step pairs in which some crane was busy, for the metrics).
``trace`` keeps the episode's physical joint actions, their events and paper rewards, so a
record can replay it in the motion mode. What a planner may ask goes through public methods:
``task_book()`` (the masks, idle cranes, tasks and carrier), ``carrier_stats()`` and
``feasible(crane, p)`` (the carrier's search, kept for the next step).
"""

from __future__ import annotations

import numpy as np

from multicrane.core.codes import Event
from multicrane.envs.infos import TaskStepFacts
from multicrane.envs.motion_mode import ModeSettings, ModeStep, physical_step
from multicrane.envs.task_observation import TaskObserver
from multicrane.sim.simulator import NOBODY, Simulator
from multicrane.tasks.book import TaskBook, TaskEvent


class TaskMode:
    """Each crane decides which task it does next (see the module doc); a ``DecisionMode``."""

    task_level = True
    wait_action = 0

    def __init__(self, sim: Simulator, settings: ModeSettings):
        if sim.auto:
            raise ValueError("decisions='task' needs the claiming mode, not auto=True")
        self.sim = sim
        self.settings = settings
        self.book = TaskBook(sim, patience=settings.task_patience)
        self.observer = TaskObserver(self.book, settings.task_site_planes)
        self.n_actions = self.book.n_actions
        self.rng: np.random.Generator | None = None

    def reset(self, rng: np.random.Generator) -> TaskStepFacts:
        """Start an episode (the simulator is already reset) drawing from ``rng``; returns
        the reset's task facts (no task events, nothing elapsed)."""
        self.rng = rng
        self.observer.reset(self.settings.step_limit)
        self.book.reset()
        self.trace: list[list[int]] = []  # physical joint actions, one list per step
        self.trace_events: list[list[Event]] = []
        self.trace_rewards: list[float] = []  # the paper reward of each physical step
        self.decisions: list[list[int]] = []
        return TaskStepFacts([() for _ in range(self.sim.n_cranes)], 0, 0)

    def observe(self) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """Every crane's observation vector and action mask, in crane order."""
        rows = self.observer.observe_all()
        return rows, list(self.observer.masks)

    def describe(self, action: int) -> str:
        if action == 0:
            return "wait"
        c, t = self.book.tasks.pairs[action - 1]
        return f"task {action - 1}: component {c} to target {t}"

    # -- what a planner may ask ---------------------------------------------------------------

    def feasible(self, crane: int, p: int) -> bool:
        """Would task ``p`` start for ``crane`` now? (``TaskBook.feasible``: the plan found
        is kept for the next step.)"""
        return self.book.feasible(crane, p)

    def task_book(self) -> TaskBook:
        """The episode's task book: tasks, masks, idle cranes, static paths, the carrier."""
        return self.book

    def carrier_stats(self) -> dict:
        """The carrier's counters (searches, expansions, claims, replans, ...)."""
        return self.book.carrier.stats

    def step(self, joint: list[int]) -> ModeStep:
        """Advance until the next decision; the environment finishes the step."""
        sim, book, settings = self.sim, self.book, self.settings
        n = sim.n_cranes
        self.decisions.append(list(joint))
        task_events: list[TaskEvent] = book.choose(joint)
        per_crane: list[list[Event]] = [[] for _ in range(n)]
        terms_sum = [0.0] * n
        total = 0.0
        elapsed = busy = 0
        held = sim.state.held  # a list the simulator changes in place
        while True:
            motion = book.motion(task_events)
            out, r, terms, paper = physical_step(sim, self.rng, settings.reward, motion)
            elapsed += 1
            # Busy: holding a component after the step, or before it (only an assembly lets
            # go of one).
            busy += n - held.count(NOBODY) + len(out.assembled_by)
            total += r
            terms_sum = [a + b for a, b in zip(terms_sum, terms, strict=True)]
            for e in out.events:
                per_crane[e.crane].append(e)
            self.trace.append(motion)
            self.trace_events.append(list(out.events))
            self.trace_rewards.append(paper)
            freed = book.after_step(task_events)
            complete = sim.done
            truncated = not complete and sim.state.step_count >= settings.step_limit
            if complete or truncated or freed or book.any_open():
                break
        facts = TaskStepFacts(
            [tuple(e for e in task_events if e[1] == i) for i in range(n)], elapsed, busy
        )
        return ModeStep(total, terms_sum, [tuple(p) for p in per_crane], facts)
