"""Large-neighbourhood search: CP-SAT proposes shorter plans than the best known, simulation judges.

``improve(manifest, instance, seconds)`` starts from the record of the instance's best-known
plan (``best.json``; ``start`` may give another record) and reads its plan
(``multicrane.suite.plan``: per crane the ordered tasks, with the record's start steps as
releases), which ``PlanFollower`` replays to the record's makespan. Until the time budget is
spent, or until the makespan is the instance's lower bound (it is then optimal), it repeats:

1. pick a neighbourhood of ``k`` tasks: a time window (the tasks starting nearest a random
   task's start), the same within two random cranes, the last tasks to finish, ``k``
   random components, or with site events the tasks nearest a breakdown (those of its crane
   first) or a late delivery; ``k`` grows from 4 (by one every 10 moves) to ``MOST_FREED`` while
   no move shortens the plan;
2. free them: CP-SAT re-places them around the rest of the plan
   (``multicrane.suite.lns_model.propose``; one worker, a short time limit, the incumbent as
   hint), which gives a new order and crane assignment per crane;
3. repair by the simulator: ``PlanFollower`` plays the new plan at the task level (each crane
   takes its next task as soon as it can; the carrier finds paths around the other cranes,
   waits where it must), stopping as soon as it runs past the incumbent's makespan;
4. keep it if its simulated makespan is not worse (equal plans move the search along).

The simulator's makespan is the truth; the relaxation only proposes. With site events the
model knows the instance's schedule (release times, breakdowns as pauses, closed pick-ups:
``multicrane.suite.lns_model``), so its proposals plan around them. The incumbent's first
try is the start plan without releases. The result is the record of the best plan, played
once more with ``record_episode`` (its makespan checked to be the one found): it never has a
longer makespan than the start plan played by the follower. With site events the follower
meets the instance's events as they come, and the search, which plays the whole episode,
learns their effect from its makespans: its plans are made knowing the events in advance.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from multicrane.bounds.first_schedule import list_schedule
from multicrane.bounds.lift_options import Tasks, task_options
from multicrane.bounds.makespan_model import limits_of, model_of
from multicrane.replay import record_file
from multicrane.replay.record import EpisodeRecord, record_episode
from multicrane.suite.bounds import read_bounds
from multicrane.suite.lns_model import choices_of, propose
from multicrane.suite.manifest import Instance, Manifest, SuiteError
from multicrane.suite.page import SEARCH, read_best_entries
from multicrane.suite.plan import (
    Plan,
    PlanFollower,
    Step,
    Timing,
    observed,
    plan_of_record,
    play_plan,
    trace_rows,
    without_releases,
)
from multicrane.suite.play import make_env, makespan_of, results_dict, results_entry
from multicrane.suite.results import read_results
from multicrane.tasks.priority_rule import list_ranks

LABEL = SEARCH  # the policy name of its results (the leaderboard's kind 'search')
SOLVER_SECONDS = 2.0  # CP-SAT's limit per move
MOST_FREED = 24  # the largest neighbourhood (tasks freed by one move)
KINDS = ("window", "cranes", "tail", "random")
EVENT_KINDS = ("breakdown", "delivery")  # also drawn when the instance has such events


@dataclass
class Incumbent:
    """A plan, the timings of its simulated episode and its makespan."""

    plan: Plan
    timing: dict[int, Timing]
    makespan: int


@dataclass
class Outcome:
    """What ``improve`` found: the best plan's record and how the search went."""

    record: EpisodeRecord
    start: int  # the start plan's makespan, as the follower plays it
    makespan: int
    tries: int  # simulated proposals
    accepted: int
    improved: int  # accepted with a shorter makespan
    seconds: float


def start_record(manifest: Manifest, instance: Instance) -> EpisodeRecord:
    """The record of the instance's best-known plan (from the file ``best.json`` names)."""
    entry = read_best_entries(manifest).get(instance.id)
    if entry is None:
        raise SuiteError(f"{instance.id}: no best-known plan in best.json to start from")
    results = read_results(manifest.folder / entry["results"])
    found = [e for e in results["instances"] if e.get("id") == instance.id]
    if not found:
        raise SuiteError(f"{instance.id}: not in {entry['results']}")
    data = {k: v for k, v in found[0]["record"].items() if k != record_file.CHECKSUM}
    return EpisodeRecord.from_dict(data, source=instance.id)


def simulate(env, plan: Plan, seed: int, cutoff: int | None = None) -> Incumbent | None:
    """Play ``plan``; its incumbent (None when it did not finish by ``cutoff``)."""
    makespan = play_plan(env, plan, seed, cutoff)
    if makespan is None:
        return None
    filled = [int(t) for t in env.sim.state.filled]
    _, timing = observed(trace_rows(env), filled, env.sim.n_cranes)
    return Incumbent(plan, timing, makespan)


def neighbourhood(kind: str, k: int, best: Incumbent, rng: np.random.Generator,
                  tasks: Tasks | None = None) -> set[int]:  # fmt: skip
    """The ``k`` components a move frees (see the module doc; ``tasks``: the instance's,
    with its events, for the kinds ``breakdown`` and ``delivery``)."""
    timing = best.timing
    comps = sorted(timing)
    if kind in EVENT_KINDS and tasks is not None:
        return _near_event(kind, k, best, rng, tasks)
    if kind == "cranes":
        cranes = {t.crane for t in timing.values()}
        if len(cranes) > 2:
            pick = set(rng.choice(sorted(cranes), 2, replace=False).tolist())
            comps = [c for c in comps if timing[c].crane in pick]
    if kind == "random":
        return set(rng.choice(comps, min(k, len(comps)), replace=False).tolist())
    if kind == "tail":
        return set(sorted(comps, key=lambda c: -timing[c].end)[:k])
    centre = timing[comps[int(rng.integers(len(comps)))]].start
    return set(sorted(comps, key=lambda c: (abs(timing[c].start - centre), c))[:k])


def event_kinds(tasks: Tasks, makespan: int) -> tuple[str, ...]:
    """The event neighbourhoods that have something to centre on before ``makespan``."""
    kinds = []
    if any(a < makespan for windows in tasks.outages for a, _ in windows):
        kinds.append("breakdown")
    if any(tasks.release.values()):
        kinds.append("delivery")
    return tuple(kinds)


def _near_event(kind: str, k: int, best: Incumbent, rng: np.random.Generator,
                tasks: Tasks) -> set[int]:  # fmt: skip
    """The ``k`` tasks nearest a random breakdown before the makespan (its crane's first,
    then by the distance of their start to it), or nearest a random late component's
    delivery (by start; the component itself first)."""
    timing = best.timing
    if kind == "breakdown":
        windows = [(a, crane) for crane, ws in enumerate(tasks.outages) for a, _ in ws
                   if a < best.makespan]  # fmt: skip
        centre, crane = windows[int(rng.integers(len(windows)))]
        near = sorted(timing, key=lambda c: (timing[c].crane != crane,
                                             abs(timing[c].start - centre), c))  # fmt: skip
        return set(near[:k])
    late = sorted(c for c, r in tasks.release.items() if r > 0 and c in timing)
    comp = late[int(rng.integers(len(late)))]
    centre = tasks.release[comp]
    return set(sorted(timing, key=lambda c: (c != comp, abs(timing[c].start - centre), c))[:k])


def improve(manifest: Manifest, instance: Instance, seconds: float, seed: int = 0,
            start: EpisodeRecord | None = None, bound: int | None = None,
            log: Callable[[str], None] | None = None) -> Outcome:  # fmt: skip
    """Search for a shorter plan of the instance for ``seconds`` (see the module doc), or
    until its makespan is the lower ``bound`` (then it is optimal)."""
    began = time.perf_counter()
    scenario = manifest.scenario(instance)
    plan, _ = plan_of_record(start or start_record(manifest, instance), scenario)
    env = make_env(manifest, instance, "task")
    best = simulate(env, plan, instance.seed)
    if best is None:
        raise SuiteError(f"{instance.id}: the start plan does not finish when followed")
    first = best.makespan
    events = None if instance.events == "none" else instance.events
    tasks = task_options(scenario, instance.cranes, instance.seed, events)
    space = _Space(tasks, choices_of(tasks), list_ranks(scenario),
                   KINDS + event_kinds(tasks, best.makespan))  # fmt: skip
    rng = np.random.default_rng(seed)
    tries = accepted = improved = stale = 0
    candidate: Plan | None = without_releases(plan)
    while candidate is not None and (bound is None or best.makespan > bound):
        if candidate != best.plan:
            tries += 1
            found = simulate(env, candidate, instance.seed, cutoff=best.makespan)
            if found is not None and found.makespan <= best.makespan:
                accepted += 1
                if found.makespan < best.makespan:
                    improved, stale = improved + 1, 0
                    if log:
                        log(f"{instance.id}: {best.makespan} -> {found.makespan} "
                            f"({time.perf_counter() - began:.0f} s)")  # fmt: skip
                best = found
        stale += 1
        candidate = _move(space, best, rng, stale, began + seconds)
    record = record_episode(env, PlanFollower(env, best.plan), instance.seed, LABEL)
    if makespan_of(record) != best.makespan:
        raise RuntimeError(f"{instance.id}: the best plan replays to {makespan_of(record)}, "
                           f"not {best.makespan}")  # fmt: skip
    return Outcome(record, first, best.makespan, tries, accepted, improved,
                   time.perf_counter() - began)  # fmt: skip


@dataclass(frozen=True)
class _Space:
    """What every move of one instance uses: its tasks, their relaxed durations per
    (target, crane), the scenario's list order of the components, the neighbourhood kinds."""

    tasks: Tasks
    relaxed: dict[int, dict[tuple[int, int], int]]
    rank: dict[int, int]
    kinds: tuple[str, ...] = KINDS


def _move(space: _Space, best: Incumbent, rng: np.random.Generator, stale: int,
          deadline: float) -> Plan | None:  # fmt: skip
    """One CP-SAT proposal around the incumbent (None once the time is spent)."""
    k = min(len(best.timing), MOST_FREED, 4 + stale // 10)
    while (left := deadline - time.perf_counter()) > 0:
        kind = space.kinds[int(rng.integers(len(space.kinds)))]
        freed = neighbourhood(kind, k, best, rng, space.tasks)
        proposal = propose(space.tasks, space.relaxed, best.plan, best.timing, freed,
                           min(SOLVER_SECONDS, left), int(rng.integers(2**31 - 1)),
                           space.rank)  # fmt: skip
        if proposal is not None:
            return proposal
    return None


def relaxation_start(manifest: Manifest, instance: Instance, seconds: float
                     ) -> EpisodeRecord | None:  # fmt: skip
    """The record of the bound relaxation's best schedule played as a plan: CP-SAT (one
    worker, ``seconds``) solves ``multicrane.bounds.makespan``'s model with the instance's
    events; each crane takes its tasks in their order there (tasks of identical cranes go
    to the crane free soonest). None when it found no schedule or the plan does not finish."""
    from ortools.sat.python import cp_model

    events = None if instance.events == "none" else instance.events
    tasks = task_options(manifest.scenario(instance), instance.cranes, instance.seed, events)
    m = model_of(tasks, list_schedule(tasks, tasks.assignment(), limits_of(tasks)))
    solver = cp_model.CpSolver()
    solver.parameters.max_time_in_seconds = float(seconds)
    solver.parameters.num_workers = 1
    solver.parameters.random_seed = 0
    if solver.Solve(m.model) not in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        return None
    chosen = sorted((solver.Value(m.start[o.comp]), solver.Value(m.end[o.comp]), o.comp, o)
                    for o, p in m.presence.items() if solver.BooleanValue(p))  # fmt: skip
    lists: list[list[Step]] = [[] for _ in range(instance.cranes)]
    free_at = [0] * instance.cranes
    for _, end, _, o in chosen:
        k = o.crane if o.crane is not None else min(range(instance.cranes), key=free_at.__getitem__)
        lists[k].append(Step(o.comp, o.target))
        free_at[k] = max(free_at[k], end)
    env = make_env(manifest, instance, "task")
    plan = tuple(tuple(x) for x in lists)
    if play_plan(env, plan, instance.seed) is None:
        return None
    return record_episode(env, PlanFollower(env, plan), instance.seed, LABEL)


def improve_track(manifest: Manifest, track: str, seconds: float, ids: list[str] | None = None,
                  seed: int = 0, log: Callable[[str], None] | None = None,
                  relaxation_seconds: float = 0.0) -> dict[str, Any]:  # fmt: skip
    """The results dict (``multicrane.suite.play``) of ``improve`` on the track's instances
    (``ids``: only these), ``seconds`` each or until the bound is reached; the best-known
    makespans stored are those the search started from. With ``relaxation_seconds``, each
    search starts from the shorter of the best-known plan and ``relaxation_start``'s."""
    bounds = read_bounds(manifest)
    best = {k: v["makespan"] for k, v in read_best_entries(manifest).items()}
    entries = []
    for instance in manifest.track(track):
        if ids is not None and instance.id not in ids:
            continue
        bound = bounds.get(instance.id, {}).get("bound")
        start = start_record(manifest, instance)
        relaxed = relaxation_start(manifest, instance, relaxation_seconds) \
            if relaxation_seconds > 0 else None  # fmt: skip
        if relaxed is not None and makespan_of(relaxed) < makespan_of(start):
            start = relaxed
        if log and relaxation_seconds > 0:
            log(f"{instance.id}: the relaxation's schedule plays to "
                f"{None if relaxed is None else makespan_of(relaxed)}")  # fmt: skip
        out = improve(manifest, instance, seconds, seed, start=start, bound=bound, log=log)
        entries.append(results_entry(instance, out.record, out.seconds, bounds, best))
        if log:
            log(f"{instance.id}: best known {best.get(instance.id)}, start {out.start}, "
                f"lns {out.makespan} ({out.tries} plans simulated, {out.accepted} kept, "
                f"{out.improved} shorter; {out.seconds:.0f} s)")  # fmt: skip
    return results_dict(manifest, track, LABEL, "task", entries)
