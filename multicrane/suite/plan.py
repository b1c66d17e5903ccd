"""Task plans: per crane the ordered (component, target) tasks, read from episodes and followed.

A ``Plan`` gives every crane its list of ``Step``s: component, target and ``release`` (the
earliest step count at which the crane may choose it; 0: as soon as it can). ``observed``
reads the plan an episode actually carried out, and each task's ``Timing`` (``start``: the
step count before its claim, ``end``: the step count when it was assembled), from the
episode's per-step event rows ``(name, crane, component)`` (a record's ``events``, or a
task-level environment's trace) and the targets the components filled: ``plan_of_record``
does it for a record. With its releases, the plan replays its episode.

``PlanFollower`` drives ``MultiCraneEnv(decisions="task")``: each idle crane takes the next
task of its list (the first whose component is still waiting to be claimed) once its release
has come, the task is allowed and the carrier's space-time search finds a path
(``env.task_feasible``); otherwise it waits. The cranes starting in one round are searched in
the scenario's list order of their components, as the prioritized planner does. The
simulator resolves the rest (waits, paths around each other). ``play_plan`` plays a plan from
the reset seed and stops early once the step count passes ``cutoff``.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from multicrane.core.codes import Status
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.replay.record import EpisodeRecord, resimulate
from multicrane.sim.simulator import NOBODY
from multicrane.tasks.priority_rule import list_ranks

_INITIAL = int(Status.INITIAL)


@dataclass(frozen=True)
class Step:
    """One task of a crane's list: bring ``comp`` to ``target``, not before ``release``."""

    comp: int
    target: int
    release: int = 0


@dataclass(frozen=True)
class Timing:
    """When a task occupied its crane: from ``start`` (claim at ``start + 1``) to ``end``."""

    crane: int
    start: int
    end: int


Plan = tuple[tuple[Step, ...], ...]  # per crane, in crane order


def observed(rows: Iterable[Iterable[tuple]], filled: list[int], n_cranes: int
             ) -> tuple[Plan, dict[int, Timing]]:  # fmt: skip
    """The plan an episode carried out (releases: its start steps) and each component's
    timing, from its per-step event rows and the target each component filled."""
    claims: dict[int, tuple[int, int]] = {}  # component -> (crane, step index of the claim)
    ends: dict[int, int] = {}
    for index, step in enumerate(rows):
        for name, crane, comp in step:
            if name == "CLAIMED":
                claims[int(comp)] = (int(crane), index)
            elif name == "ASSEMBLED":
                ends[int(comp)] = index + 1
    timing = {c: Timing(k, s, ends[c]) for c, (k, s) in claims.items() if c in ends}
    lists: list[list[Step]] = [[] for _ in range(n_cranes)]
    for c in sorted(timing, key=lambda c: (timing[c].start, c)):
        lists[timing[c].crane].append(Step(c, int(filled[c]), timing[c].start))
    return tuple(tuple(x) for x in lists), timing


def plan_of_record(record: EpisodeRecord, scenario=None) -> tuple[Plan, dict[int, Timing]]:
    """The plan and timings of a record's episode (re-simulated for the filled targets)."""
    env, _, _ = resimulate(record, scenario)
    filled = [int(t) for t in env.sim.state.filled]
    return observed(record.events, filled, record.n_cranes)


def without_releases(plan: Plan) -> Plan:
    """The same lists, each task as soon as the crane can."""
    return tuple(tuple(Step(s.comp, s.target) for s in steps) for steps in plan)


class PlanFollower:
    """Follow a plan at the task level (see the module doc)."""

    def __init__(self, env: MultiCraneEnv, plan: Plan, seed=None):
        base = env.unwrapped if hasattr(env, "unwrapped") else env
        if not getattr(base.mode, "task_level", False):
            raise ValueError("PlanFollower drives MultiCraneEnv(decisions='task')")
        if len(plan) != base.sim.n_cranes:
            raise ValueError(f"a plan for {len(plan)} cranes, the site has {base.sim.n_cranes}")
        self.env = base
        self.plan = plan
        self.seed = seed
        self._list_rank = list_ranks(base.scenario)

    def next_step(self, crane: int) -> Step | None:
        """The crane's next task: the first of its list whose component awaits a claim."""
        status = self.env.sim.state.status
        return next((s for s in self.plan[crane] if status[s.comp] == _INITIAL), None)

    def __call__(self, observations) -> dict:
        env = self.env
        book = env.mode.task_book()
        T = env.sim.state.step_count
        actions = dict.fromkeys(env.possible_agents, 0)
        idle = book.idle_cranes()
        if not idle or not book.carrier.may_start(T):
            return actions
        due = []
        for k in idle:
            step = self.next_step(k)
            if step is not None and step.release <= T:
                due.append((self._list_rank.get(step.comp, step.comp), k, step))
        index = book.tasks.index
        for _, k, step in sorted(due):
            p = index.get((step.comp, step.target), NOBODY)
            if p != NOBODY and env.task_feasible(k, p):
                actions[env.possible_agents[k]] = 1 + p
        return actions


def play_plan(env: MultiCraneEnv, plan: Plan, seed: int, cutoff: int | None = None
              ) -> int | None:  # fmt: skip
    """The makespan of following ``plan`` from ``reset(seed)`` (None: not completed, or
    still running after ``cutoff`` steps); the episode's trace stays in ``env.mode``."""
    observations, _ = env.reset(seed=seed)
    follower = PlanFollower(env, plan, seed)
    first = env.possible_agents[0]
    while True:
        observations, _, terminations, truncations, _ = env.step(follower(observations))
        if terminations[first]:
            return int(env.sim.state.step_count) if env.sim.done else None
        if truncations[first] or (cutoff is not None and env.sim.state.step_count > cutoff):
            return None


def trace_rows(env: MultiCraneEnv) -> list[list[tuple[str, int, int]]]:
    """The event rows of a task-level episode's physical steps (as a record keeps them)."""
    return [[(e.type.name, int(e.crane), int(e.component)) for e in step]
            for step in env.mode.trace_events]  # fmt: skip


__all__ = ["Plan", "PlanFollower", "Step", "Timing", "observed", "plan_of_record",
           "play_plan", "trace_rows", "without_releases"]  # fmt: skip
