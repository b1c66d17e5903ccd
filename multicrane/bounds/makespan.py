"""A proven lower bound on the makespan of one episode, from a CP-SAT scheduling relaxation.

``lower_bound(scenario, n_cranes, seed)`` bounds the makespan (``sim.state.step_count`` when
the last component is assembled) of the multi-agent claiming mode (``auto=False``) for the
episode that ``reset(seed=seed)`` starts: the start (yard poses, pre-built components) is drawn
with ``np.random.default_rng(seed)`` exactly as the environment does. It holds for every
policy, whatever order the cranes act in within a step.

**The relaxation.** Each component that is not pre-built is one task, done by one crane for
one target it may fill. An *option* is a (crane, target) pair; its duration is

    1 (the claim step, which lifts the component to its pick-up pose)
    + the fewest moves of the rigid component from its pick-up pose to the target
    + ``assembly_steps``.

A real episode has exactly this shape per component: a crane claims it at step ``s + 1``,
moves it ``m`` times (arriving in the last move step, or in the claim step if ``m = 0``) and
assembles it for ``assembly_steps`` steps, then may claim again at the next step; so the
component occupies its crane over ``[s, s + duration)`` with ``m`` at least the static
shortest path. Each relaxation below only admits more schedules than the simulator does, so
the optimum of the relaxation is at most the best achievable makespan:

- *Other components are ignored* by the paths (only walls, ground, sky and obstacles block),
  and nothing stops a path from crossing the pose of another target: real paths are at least
  as long. A component that arrives on a target on its way to another has filled that target,
  which is another option of the model, with a duration no longer than the real one.
- *Cranes do not interact*: no collisions, no waiting for a blocked pick-up pose or cell.
- *Readiness is relaxed*: a target may be filled once every support target holds an assembled
  component (``Site.target_supports``); the model asks only that the component *arrives* no
  earlier than the step in which the last support is assembled (``s + 1 + m >= end(support)``;
  cranes act one after another in a step, so the same step is possible), and that a beam (or
  a panel: ``kinds.waits_for_target``) is
  *claimed* no earlier than the step in which some target it may fill becomes supported (the
  simulator lets a beam be claimed only then, and also asks that target to be free, which the
  model does not). A column may be claimed before its target is supported, as in the
  simulator. Pre-built components are assembled at step 0.
- *Targets*: each component fills exactly one target it may fill and each target not taken
  by a pre-built component is filled exactly once (there are as many of them as components to
  place), as in every finished episode.
- *Reach* (``Scenario.crane_specs``): a crane's options for a component exist only when its
  zone holds the pick-up pose, the target and a path between them, every pose of the path in
  the zone (no hand-over between cranes), and the path length is measured inside the zone.
  Without reach the cranes are identical; one cumulative resource of capacity ``n_cranes``
  then replaces the per-crane no-overlap constraints: interval graphs are perfect, so unit
  tasks that never exceed ``n`` at a time can always be given to ``n`` cranes, and the two
  models have the same optimum.

- *Site events in hindsight* (``events``): an instance's schedule is drawn at reset from the
  seed and no action changes it, so the bound may know it. A late component is claimed no
  earlier than it is due (``start >= arrival``: it appears at that time at the earliest). A
  breakdown ``[a, b)`` of crane ``k`` pauses whatever ``k`` holds; the task's interval on
  ``k`` ends after ``duration`` up steps (``multicrane.bounds.outages.add_paused_task``) and
  its arrival counts back ``assembly_steps`` from its end (``end - assembly_steps >=`` the
  support's end): mapping an episode's task to the last ``duration`` up steps before its
  assembly ends gives a schedule of this model. Cranes with breakdowns get options per
  crane. Closures enter through the heads (``multicrane.bounds.floors.option_heads``):
  with the option chosen, its task starts no earlier than ``1 + moves`` up steps of its
  crane before its arrival's head (the last ``assembly_steps`` of its ``duration`` up steps
  come after the arrival) and ends no earlier than its end head (docs/bound.md).

Cuts added (each implied by the model, stated to help the solver prove the bound): the
workload floor with distinct targets, ``makespan >= ceil(W / n_cranes)`` with ``W`` the least
total duration of an assignment of the components to distinct targets (a minimum-cost
matching, ``Tasks.assignment``; at least the sum of each task's shortest option), and
``makespan >=`` each task's shortest option, both as the makespan's lower limit;
``n_cranes * makespan >=`` the chosen durations' sum; per crane with reach,
``makespan >=`` its chosen durations' sum. A list schedule of that assignment
(``multicrane.bounds.first_schedule``) is handed to the solver as a hint.

``BoundResult.value`` is the optimum of the relaxation when the solver proves it
(``status == "optimal"``); otherwise the solver's best proven bound (``"feasible"``: it found
a schedule of the relaxation and stopped with a gap; ``"unknown"``: no schedule within the
time limit); never an incumbent. The solve is deterministic when it proves optimality.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

from multicrane.bounds.first_schedule import list_schedule
from multicrane.bounds.first_schedule import makespan as schedule_makespan
from multicrane.bounds.floors import floor_of
from multicrane.bounds.lift_options import Tasks, task_options
from multicrane.bounds.makespan_model import build_model, limits_of
from multicrane.core.schema import Scenario
from multicrane.scenario.loader import load_scenario
from multicrane.sim.events import EventSchedule, EventSpec


@dataclass(frozen=True)
class BoundResult:
    """A proven lower bound on the makespan of the episode ``reset(seed)`` starts.

    ``value``: the bound, in simulator steps. ``status``: ``"optimal"`` (the relaxation's
    optimum was proven: ``value`` is it), ``"feasible"`` (stopped with a gap: ``value`` is the
    solver's best proven bound) or ``"unknown"`` (no schedule of the relaxation found in time:
    ``value`` is the best proven bound, at least the workload floor).
    ``relaxation_makespan``: the best schedule of the relaxation found (None if none).
    """

    value: int
    status: str
    relaxation_makespan: int | None
    wall_s: float
    n_tasks: int
    n_cranes: int
    seed: int
    scenario: str
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def optimal(self) -> bool:
        """True when the solver proved the relaxation's optimum."""
        return self.status == "optimal"

    def as_dict(self) -> dict:
        return {
            "scenario": self.scenario,
            "cranes": self.n_cranes,
            "seed": self.seed,
            "bound": self.value,
            "status": self.status,
            "relaxation_optimal": self.optimal,
            "relaxation_makespan": self.relaxation_makespan,
            "wall_s": round(self.wall_s, 3),
            "tasks": self.n_tasks,
            "notes": list(self.notes),
        }


# -- solving ---------------------------------------------------------------------------------------


def lower_bound(
    scenario: str | Path | Scenario,
    n_cranes: int | None = None,
    seed: int = 0,
    time_limit: float = 60.0,
    workers: int = 2,
    events: str | EventSpec | EventSchedule | None = None,
) -> BoundResult:
    """A proven lower bound on the makespan of the episode ``reset(seed=seed)`` starts.

    ``scenario``: a ``Scenario``, a shipped name or a path; ``n_cranes``: default the
    scenario's; ``time_limit`` (seconds) and ``workers`` go to CP-SAT. ``events``: None
    bounds the undisturbed site (a bound for every event schedule too); a level name or an
    ``EventSpec`` bounds the episode ``MultiCraneEnv(events=events).reset(seed)`` plays,
    knowing its schedule's late deliveries and breakdowns; an ``EventSchedule``, the episode
    with that schedule (a record's). See the module doc for the model and ``BoundResult`` for
    the meaning of the status.
    """
    if not time_limit > 0:
        raise ValueError(f"time_limit must be positive, got {time_limit!r}")
    if workers < 1:
        raise ValueError(f"workers must be at least 1, got {workers!r}")
    began = time.perf_counter()
    tasks = task_options(load_scenario(scenario), n_cranes, seed, events)
    return solve_tasks(tasks, seed, time_limit, workers, began)


def solve_tasks(
    tasks: Tasks, seed: int = 0, time_limit: float = 60.0, workers: int = 2,
    began: float | None = None,
) -> BoundResult:  # fmt: skip
    """Solve the relaxation of ``tasks`` (``task_options``' for ``seed``): see ``lower_bound``.
    ``began``: the ``time.perf_counter()`` the reported seconds count from (default: now)."""
    from ortools.sat.python import cp_model

    began = time.perf_counter() if began is None else began
    scenario = tasks.scenario

    def result(value: int, status: str, incumbent: int | None, notes: list[str]):
        return BoundResult(
            value=int(value),
            status=status,
            relaxation_makespan=incumbent,
            wall_s=time.perf_counter() - began,
            n_tasks=len(tasks.comps),
            n_cranes=tasks.n_cranes,
            seed=seed,
            scenario=scenario.name,
            notes=tuple(notes),
        )

    if not tasks.comps:
        return result(0, "optimal", 0, ["every component is pre-built"])
    floor = floor_of(tasks)
    plan = list_schedule(tasks, tasks.assignment(), limits_of(tasks))
    notes = [
        f"{len(tasks.options)} options; workload floor {tasks.workload_floor}, "
        f"{tasks.assignment_floor()} with distinct targets; list schedule "
        f"{schedule_makespan(tasks, plan)}",
        "reach: per-crane zones" if scenario.crane_specs else "no reach: identical cranes",
    ]
    if tasks.has_events:
        late = sum(r > 0 for r in tasks.release.values())
        down = sum(len(o) for o in tasks.outages)
        notes.append(f"events in hindsight: {late} late components, {down} breakdowns "
                     f"(options per crane); floor {floor}")  # fmt: skip
    model, _ = build_model(tasks, hint=plan)
    solver = cp_model.CpSolver()
    solver.parameters.max_time_in_seconds = float(time_limit)
    solver.parameters.num_workers = int(workers)
    solver.parameters.random_seed = 0
    code = solver.Solve(model)
    if code == cp_model.OPTIMAL:
        best = round(solver.ObjectiveValue())
        return result(best, "optimal", best, notes)
    if code in (cp_model.FEASIBLE, cp_model.UNKNOWN):
        incumbent = round(solver.ObjectiveValue()) if code == cp_model.FEASIBLE else None
        value = max(floor, math.ceil(solver.BestObjectiveBound() - 1e-6))
        notes.append(f"stopped after {time_limit:g} s without proving the relaxation's optimum")
        status = "feasible" if code == cp_model.FEASIBLE else "unknown"
        return result(value, status, incumbent, notes)
    raise RuntimeError(
        f"{scenario.source}: the relaxation has no schedule ({solver.StatusName(code)}); "
        "this is a bug: the list schedule is one"
    )
