"""The task-level step of ``MultiCraneEnv(decisions="task")``: choices in, simulated steps out.

One ``step`` takes each idle crane's choice (``0`` wait, ``1 + p`` task ``p``; a busy crane
may only send ``0``: continue), starts the chosen tasks in crane order (``multicrane.tasks.book``),
then advances the simulator one physical step at a time with the carrier's motion actions,
through the environment's own physical step (the same ``Simulator.step``, the crane order
drawn from the episode's generator), until (a) a crane that was busy becomes idle, (b) after
a step some idle crane has an allowed task, or (c) the building is complete or the step
limit truncates. At least one simulated step passes, so "wait" waits one step at least.

The simulator's step count is the clock: the step limit, the makespan and the metrics count
simulated steps. The reward is the sum over the elapsed steps. The infos
(``multicrane.envs.infos``) count the crane's physical events of every elapsed step and its
task events (``multicrane.tasks.book``), and give ``elapsed`` (simulated steps of this env step)
and ``crane_steps`` (crane x step pairs in which some crane was busy, for the metrics).
``trace`` keeps the episode's physical joint actions, their events and paper rewards, so a
record can replay it in the motion mode.
"""

from __future__ import annotations

from multicrane.core.codes import Event
from multicrane.envs.infos import TaskStepFacts
from multicrane.envs.task_observation import TaskObserver
from multicrane.sim.simulator import NOBODY
from multicrane.tasks.book import TaskBook, TaskEvent


class TaskMode:
    """The task-level half of a ``MultiCraneEnv`` (the env delegates to it)."""

    def __init__(self, env, patience: int, site_planes: bool):
        self.env = env
        self.book = TaskBook(env.sim, patience=patience)
        self.observer = TaskObserver(self.book, site_planes)
        self.n_actions = self.book.n_actions

    def reset(self) -> None:
        self.book.reset()
        self.trace: list[list[int]] = []  # physical joint actions, one list per step
        self.trace_events: list[list[Event]] = []
        self.trace_rewards: list[float] = []  # the paper reward of each physical step
        self.decisions: list[list[int]] = []

    def observe(self) -> list:
        return self.observer.observe_all()

    def describe(self, action: int) -> str:
        if action == 0:
            return "wait"
        c, t = self.book.tasks.pairs[action - 1]
        return f"task {action - 1}: component {c} to target {t}"

    def feasible(self, crane: int, p: int) -> bool:
        return self.book.feasible(crane, p)

    def step(self, joint: list[int]):
        """Advance until the next decision: ``(team reward, reward terms, events per crane,
        task facts for the infos)``; the environment finishes the step (``MultiCraneEnv``)."""
        env, sim, book = self.env, self.env.sim, self.book
        n = sim.n_cranes
        self.decisions.append(list(joint))
        task_events: list[TaskEvent] = book.choose(joint)
        per_crane: list[list[Event]] = [[] for _ in range(n)]
        terms_sum = [0.0] * n
        total = 0.0
        elapsed = busy = 0
        while True:
            motion = book.motion(task_events)
            held_before = [c != NOBODY for c in sim.state.held]
            out, r, terms, paper = env._physical_step(motion)
            elapsed += 1
            busy += sum(
                1 for i in range(n) if held_before[i] or sim.state.held[i] != NOBODY
            )
            total += r
            for i in range(n):
                terms_sum[i] += terms[i]
            for e in out.events:
                per_crane[e.crane].append(e)
            self.trace.append(motion)
            self.trace_events.append(list(out.events))
            self.trace_rewards.append(paper)
            freed = book.after_step(task_events)
            complete = sim.done
            truncated = not complete and sim.state.step_count >= env.step_limit
            if complete or truncated or freed or book.any_open():
                break
        facts = TaskStepFacts(
            [tuple(e for e in task_events if e[1] == i) for i in range(n)], elapsed, busy
        )
        return total, terms_sum, [tuple(p) for p in per_crane], facts
