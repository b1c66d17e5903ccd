"""Plans read from records replay them; the neighbourhood search never does worse, and verifies."""

from __future__ import annotations

import json

import numpy as np
import pytest

from multicrane.bounds.lift_options import task_options
from multicrane.cli import main
from multicrane.replay import record_file
from multicrane.replay.record import EpisodeRecord
from multicrane.suite.bounds import read_bounds
from multicrane.suite.lns import (
    Incumbent,
    event_kinds,
    improve,
    improve_track,
    neighbourhood,
    relaxation_start,
    simulate,
    start_record,
)
from multicrane.suite.lns_model import choices_of, durations, open_times, propose
from multicrane.suite.manifest import read_manifest
from multicrane.suite.plan import PlanFollower, plan_of_record, play_plan, without_releases
from multicrane.suite.play import make_env
from multicrane.suite.results import read_results
from multicrane.suite.verify import verify, verify_entry

TINY = "small-01"  # 13 components, 3 cranes
EVENTS = "small-events-03"  # 24 components, 3 cranes; late deliveries, breakdowns, closures


@pytest.fixture(scope="module")
def v1():
    return read_manifest("v1")


def _record(v1, policy: str, instance: str, track: str = "small") -> EpisodeRecord:
    results = read_results(v1.folder / "results" / f"{track}-{policy}.json")
    entry = next(e for e in results["instances"] if e["id"] == instance)
    return EpisodeRecord.from_dict({k: v for k, v in entry["record"].items() if k != "checksum"})


@pytest.mark.parametrize("policy", ["lookahead", "prioritized"])
def test_the_plan_of_a_record_replays_to_its_makespan(v1, policy):
    instance = v1.get(TINY)
    record = _record(v1, policy, TINY)
    plan, timing = plan_of_record(record, v1.scenario(instance))
    comps = [s.comp for steps in plan for s in steps]
    assert sorted(comps) == sorted(timing) and len(set(comps)) == len(comps)
    assert max(t.end for t in timing.values()) == record.metrics["steps"]
    env = make_env(v1, instance, "task")
    assert play_plan(env, plan, instance.seed) == record.metrics["steps"]


def test_a_plan_found_replays_to_its_own_timings(v1):
    instance = v1.get(TINY)
    plan, _ = plan_of_record(_record(v1, "prioritized", TINY), v1.scenario(instance))
    env = make_env(v1, instance, "task")
    found = simulate(env, without_releases(plan), instance.seed)
    again = simulate(env, found.plan, instance.seed)
    assert (again.makespan, again.timing) == (found.makespan, found.timing)
    assert play_plan(env, found.plan, instance.seed, cutoff=found.makespan - 5) is None


def test_the_follower_drives_the_task_level_only(v1):
    instance = v1.get(TINY)
    with pytest.raises(ValueError, match="decisions='task'"):
        PlanFollower(make_env(v1, instance, "motion"), ((),) * instance.cranes)


def test_a_move_that_frees_nothing_keeps_every_crane_order(v1):
    instance = v1.get(TINY)
    plan, timing = plan_of_record(_record(v1, "lookahead", TINY), v1.scenario(instance))
    tasks = task_options(v1.scenario(instance), instance.cranes, instance.seed)
    kept = propose(tasks, choices_of(tasks), plan, timing, set(), time_limit=5.0)
    assert kept == without_releases(plan)
    freed = neighbourhood("window", 5, Incumbent(plan, timing, 0), np.random.default_rng(1))
    moved = propose(tasks, choices_of(tasks), plan, timing, freed, time_limit=5.0)
    assert sorted(s.comp for steps in moved for s in steps) == sorted(timing)


@pytest.mark.parametrize("kind", ["window", "cranes", "tail", "random"])
def test_a_neighbourhood_frees_k_placed_tasks(v1, kind):
    instance = v1.get(TINY)
    plan, timing = plan_of_record(_record(v1, "lookahead", TINY), v1.scenario(instance))
    freed = neighbourhood(kind, 4, Incumbent(plan, timing, 0), np.random.default_rng(0))
    assert len(freed) == 4 and freed <= set(timing)


def _events_case(v1):
    instance = v1.get(EVENTS)
    record = _record(v1, "prioritized", EVENTS, "small-events")
    plan, timing = plan_of_record(record, v1.scenario(instance))
    tasks = task_options(v1.scenario(instance), instance.cranes, instance.seed, instance.events)
    return instance, plan, timing, tasks


def test_with_events_a_task_takes_its_up_steps_and_the_plan_is_a_solution(v1):
    instance, plan, timing, tasks = _events_case(v1)
    assert any(tasks.outages) and any(tasks.release.values())
    kept = durations(choices_of(tasks), plan, timing, set(), tasks.outages)
    paused = [c for c, when in timing.items()
              if next(iter(kept[c].values())) < when.end - when.start]  # fmt: skip
    assert paused  # some task of the record held its component through a breakdown
    assert propose(tasks, choices_of(tasks), plan, timing, set(), 10.0) == without_releases(plan)


def test_with_events_a_start_is_due_and_not_in_a_closure_of_its_pickup(v1):
    instance, plan, timing, tasks = _events_case(v1)
    assert tasks.closed_lift
    for c, when in timing.items():
        domain = open_times(tasks, c, 500)
        allowed = {t for t in range(501) if domain.contains(t)}
        closed = {t for a, b in tasks.closed_lift.get(c, ()) for t in range(a, b)}
        assert allowed == set(range(tasks.release[c], 501)) - closed
        assert when.start in allowed  # the record's own start: the hint stays a solution


def test_event_neighbourhoods_free_k_tasks_and_proposals_place_every_task(v1):
    instance, plan, timing, tasks = _events_case(v1)
    best = Incumbent(plan, timing, max(t.end for t in timing.values()))
    assert set(event_kinds(tasks, best.makespan)) == {"breakdown", "delivery"}
    rng = np.random.default_rng(3)
    for kind in ("breakdown", "delivery"):
        freed = neighbourhood(kind, 6, best, rng, tasks)
        assert len(freed) == 6 and freed <= set(timing)
        moved = propose(tasks, choices_of(tasks), plan, timing, freed, 10.0)
        assert sorted(s.comp for steps in moved for s in steps) == sorted(timing)
    assert event_kinds(task_options(v1.scenario(v1.get(TINY)), 3, 0), 100) == ()


def test_the_search_never_returns_a_worse_plan_and_its_record_verifies(v1):
    instance = v1.get(TINY)
    start = _record(v1, "prioritized", TINY)
    out = improve(v1, instance, seconds=4.0, start=start)
    assert out.makespan <= out.start <= start.metrics["steps"]
    assert out.record.metrics["steps"] == out.makespan and out.record.policy == "lns"
    entry = {"makespan": out.makespan, "success": True, "record": _with_checksum(out.record)}
    verify_entry(entry, instance, v1)


def test_the_search_stops_at_the_bound(v1):
    instance = v1.get(TINY)
    start = start_record(v1, instance)
    out = improve(v1, instance, seconds=60.0, start=start, bound=start.metrics["steps"])
    assert (out.tries, out.makespan) == (0, start.metrics["steps"])


def test_improve_on_a_tiny_instance_end_to_end(v1, tmp_path, capsys):
    out = tmp_path / "small-lns.json"
    status = main(["suite", "improve", "v1", "--track", "small", "--instances", TINY,
                   "--seconds", "3", "--out", str(out)])  # fmt: skip
    assert status == 0
    results = read_results(out)
    assert (results["policy"], results["decisions"], results["track"]) == ("lns", "task", "small")
    assert [e["id"] for e in results["instances"]] == [TINY]
    assert verify(results, v1)[0]["makespan"] <= results["instances"][0]["best_known"]
    assert main(["suite", "verify", str(out)]) == 0
    assert main(["suite", "improve", "v1", "--track", "small", "--instances", "nope"]) != 0
    capsys.readouterr()


@pytest.mark.parametrize("name", [TINY, "small-events-01"])  # identical cranes; one, events
def test_the_relaxations_schedule_plays_as_a_plan_and_its_record_verifies(v1, name):
    instance = v1.get(name)
    record = relaxation_start(v1, instance, 5.0)
    assert record is not None and record.policy == "lns"
    makespan = record.metrics["steps"]
    assert makespan >= read_bounds(v1)[name]["bound"]
    verify_entry({"makespan": makespan, "success": True, "record": _with_checksum(record)},
                 instance, v1)  # fmt: skip


def test_improve_can_start_from_the_relaxation(v1, tmp_path, capsys):
    out = tmp_path / "small-lns.json"
    assert main(["suite", "improve", "v1", "--track", "small", "--instances", TINY, "--seconds",
                 "1", "--from-relaxation", "3", "--out", str(out)]) == 0  # fmt: skip
    assert "the relaxation's schedule plays to" in capsys.readouterr().err
    assert verify(read_results(out), v1)[0]["makespan"] <= read_results(out)["instances"][0][
        "best_known"]


def test_improve_track_keeps_the_instances_asked(v1):
    results = improve_track(v1, "small-reach", 1.0, ids=["small-reach-04"])
    assert [e["id"] for e in results["instances"]] == ["small-reach-04"]
    json.dumps(results)  # a results file holds plain JSON


def _with_checksum(record: EpisodeRecord) -> dict:
    data = record.to_dict()
    return {**data, record_file.CHECKSUM: record_file.checksum(data)}
