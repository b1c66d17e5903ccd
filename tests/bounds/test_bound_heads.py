"""The option heads that carry closures into the bound hold in real episodes, on many sites.

``floors.option_heads`` gives each option lower limits on the start of its task's last
``duration`` up steps and on its end; the CP-SAT model and the energy floors rely on them.
Every episode a planner plays with site events must meet them for the options it took, the
floors must stay below its makespan, the list schedule must be a schedule of the model, and
on the suite's event tracks the floor must stay below every instance's best-known plan.
"""

from __future__ import annotations

import pytest

import multicrane
import policies
from multicrane.bounds.first_schedule import list_schedule
from multicrane.bounds.floors import floor_of, option_heads
from multicrane.bounds.lift_options import Tasks, task_options
from multicrane.bounds.makespan_model import build_model, limits_of
from multicrane.bounds.outages import first_up
from multicrane.replay.record import record_episode
from multicrane.scenario.generator import generate
from multicrane.suite.manifest import read_manifest
from multicrane.suite.page import read_best
from multicrane.suite.plan import observed

SITES = [  # family, generator seed, parameters, cranes, events level
    ("frame", 41, {"bays_x": 2, "bays_y": 1, "storeys": 1}, 2, "high"),
    ("hall", 42, {"bays_x": 2, "bays_y": 1}, 3, "high"),
    ("tower", 43, {"storeys": 2}, 2, "high"),
    ("frame", 44, {"bays_x": 1, "bays_y": 1, "storeys": 2}, 1, "high"),
    ("hall", 45, {"bays_x": 1, "bays_y": 1}, 2, "low"),
    ("frame", 46, {"bays_x": 2, "bays_y": 1, "storeys": 1, "reach": True}, 3, "high"),
    ("tower", 47, {"storeys": 3}, 3, "high"),
    ("frame", 48, {"bays_x": 2, "bays_y": 2, "storeys": 1}, 4, "high"),
]


def _last_up_steps_start(outages, end: int, duration: int) -> int:
    """The start of the last ``duration`` up steps before ``end``."""
    t, count = end, 0
    while count < duration:
        t -= 1
        count += first_up(outages, t) == t
    return t


def _played(scn, n: int, level: str, planner: str, seed: int):
    env = multicrane.parallel_env(scn, n_cranes=n, events=level)
    record = record_episode(env, policies.make(planner, env, seed=seed), seed)
    filled = [int(t) for t in env.sim.state.filled]
    _, timing = observed(record.events, filled, n)
    return record.metrics, timing, filled


def _check_episode(tasks: Tasks, metrics, timing, filled) -> int:
    """Assert the heads and the floor hold for one episode; how many tasks were checked."""
    heads = option_heads(tasks)
    for c, when in timing.items():
        taken = [o for o in tasks.options if o.comp == c and o.target == filled[c]
                 and o.crane in (None, when.crane)]  # fmt: skip
        assert taken, (c, filled[c], when)
        for o in taken:
            outages = tasks.outages[when.crane] if tasks.outages else ()
            begun = _last_up_steps_start(outages, when.end, o.duration)
            assert begun >= when.start  # its claim is one of those up steps, or earlier
            assert heads[o][0] <= begun and heads[o][1] <= when.end, (o, heads[o], when)
    if metrics["success"]:
        assert floor_of(tasks) <= metrics["steps"]
    return len(timing)


@pytest.mark.parametrize(("family", "gen_seed", "params", "n", "level"), SITES)
def test_real_episodes_meet_every_option_head_and_the_floor(family, gen_seed, params, n, level):
    scn = generate(family, gen_seed, random_start=False, obstacles=1, cranes=n, **params)
    checked = 0
    for seed in (0, 1, 2):
        tasks = task_options(scn, n, seed, level)
        for planner in ("prioritized", "greedy"):
            checked += _check_episode(tasks, *_played(scn, n, level, planner, seed))
    assert checked > 0


@pytest.mark.parametrize(("family", "gen_seed", "params", "n", "level"), SITES[:4])
def test_the_list_schedule_within_the_heads_is_a_schedule_of_the_model(
    family, gen_seed, params, n, level
):
    from ortools.sat.python import cp_model

    scn = generate(family, gen_seed, random_start=False, obstacles=1, cranes=n, **params)
    tasks = task_options(scn, n, 0, level)
    assert tasks.has_events
    model, _ = build_model(tasks, hint=list_schedule(tasks, tasks.assignment(), limits_of(tasks)))
    solver = cp_model.CpSolver()
    solver.parameters.fix_variables_to_their_hinted_value = True
    solver.parameters.num_workers = 1
    solver.parameters.max_time_in_seconds = 10
    assert solver.Solve(model) in (cp_model.OPTIMAL, cp_model.FEASIBLE)


@pytest.mark.parametrize("track", ["small-events", "medium-events"])
def test_the_floor_stays_below_every_best_known_plan_of_the_suite(track):
    v1 = read_manifest("v1")
    best = read_best(v1)
    for instance in v1.track(track):
        tasks = task_options(v1.scenario(instance), instance.cranes, instance.seed,
                             instance.events)  # fmt: skip
        assert floor_of(tasks) <= best[instance.id], instance.id
