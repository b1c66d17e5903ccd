"""The event-aware makespan bound: late deliveries as release times, breakdowns as pauses.

Table-driven on the hand-built sites of test_bound (each case's bound is attained by a
scripted play with the same schedule), the crane-time arithmetic of
``multicrane.bounds.outages``, the schedule being the one the environment draws, and the
bound never above a planner's makespan on generated sites with and without events and reach.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_bound import C_PREBUILT, B, C, D, scenario

import multicrane
import policies
from multicrane.bounds.lift_options import task_options
from multicrane.bounds.makespan import lower_bound
from multicrane.bounds.outages import counted_back, finish, first_up, up_steps, work_floor
from multicrane.core.codes import ASSEMBLE, CLAIM_BASE, WAIT, Status
from multicrane.episodes.rollout import run_episode
from multicrane.scenario.generator import generate
from multicrane.sim import shortest_paths
from multicrane.sim.events import EventSchedule, Outage, closure
from multicrane.sim.simulator import NOBODY, Simulator
from multicrane.sim.site import Site

# -- crane time ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("outages", "start", "duration", "up", "end"),
    [
        ((), 0, 11, 0, 11),
        (((3, 7),), 0, 11, 0, 15),  # paused 4 steps in the middle
        (((3, 7),), 3, 11, 7, 18),  # down when due: starts when back
        (((11, 20),), 0, 11, 0, 11),  # ends as the breakdown begins
        (((2, 4), (6, 9)), 0, 5, 0, 10),  # two pauses
        (((2, 4), (6, 9)), 5, 3, 5, 11),  # the second one only
    ],
)
def test_a_task_ends_after_its_work_in_up_steps(outages, start, duration, up, end):
    assert first_up(outages, start) == up
    assert finish(outages, up, duration) == end
    assert up_steps(outages, up, end) == duration


@pytest.mark.parametrize(
    ("outages", "t", "n", "earliest"),
    [
        ((), 20, 4, 16),  # 4 up steps before 20: from 16
        (((17, 19),), 20, 4, 14),  # two of the steps before 20 are down
        (((10, 16),), 20, 4, 10),  # the steps just before 16 are down: 10 .. 15 count none
        (((0, 3),), 5, 4, 0),  # fewer than 4 up steps before 5: from 0
        ((), 3, 0, 3),
    ],
)
def test_a_tasks_last_up_steps_are_counted_back(outages, t, n, earliest):
    assert counted_back(outages, t, n) == earliest
    assert up_steps(outages, earliest, t) <= n
    assert earliest == 0 or up_steps(outages, earliest - 1, t) > n


def test_the_work_floor_counts_only_up_steps():
    assert work_floor(((), ()), 0, 21) == 11  # ceil(21 / 2)
    assert work_floor((((0, 30),), ()), 0, 21) == 21  # crane 0 down: crane 1 alone
    assert work_floor((((0, 5),), ()), 0, 21) == 13  # 13 + 8 up steps
    assert work_floor(((), ()), 10, 4) == 12


# -- scripted plays with a schedule --------------------------------------------------------------


def schedule(scn, arrival: dict[str, int] = (), outages=(), closures=()) -> EventSchedule:
    due = np.zeros(scn.n_components, dtype=np.int64)
    for name, step in dict(arrival).items():
        due[scn.index_of(name)] = step
    site = Site(scn)
    shut = [closure(site, box, start, end) for box, start, end in closures]
    return EventSchedule(due, [Outage(*o) for o in outages], shut)


def play(scn, n: int, events: EventSchedule, claims: dict[int, list[tuple[int, str]]]) -> int:
    """Each crane claims its ``(step, component)`` in order, each in that step or, if its
    crane is down or the component is not claimable then (not due, pick-up closed), as soon
    after as it may, carries it along a shortest path (hovering while its next cell is
    closed) and assembles it. Returns the makespan."""
    sim = Simulator(scn, n_cranes=n)
    sim.reset(np.random.default_rng(0), schedule=events)
    todo = {k: [(t, scn.index_of(c)) for t, c in comps] for k, comps in claims.items()}
    paths: dict[int, list[int]] = {}
    while not sim.done:
        actions = []
        for k in range(n):
            comp = sim.state.held[k]
            if not sim.crane_up(k) or sim.state.assembling[k]:
                actions.append(WAIT)
            elif comp == NOBODY:
                want = todo.get(k, [])
                step = sim.state.step_count + 1
                ok = want and want[0][0] <= step and sim.claimable(want[0][1])
                actions.append(CLAIM_BASE + want.pop(0)[1] if ok else WAIT)
            elif sim.state.status[comp] == Status.ARRIVED:
                actions.append(ASSEMBLE)
            else:
                if comp not in paths:
                    dist = shortest_paths.field_from(sim, comp, [])
                    goal = shortest_paths.goal_positions(sim, comp, [comp])[0]
                    paths[comp] = shortest_paths.path_to(sim, dist, goal, set())
                closed = not sim.move_ok(comp, paths[comp][0])  # into a closed cell: hover
                actions.append(WAIT if closed else paths[comp].pop(0))
        out = sim.step(actions)
        bad = [e for e in out.events if e.type.name in ("ILLEGAL", "BLOCKED", "LIFT_BLOCKED")]
        assert not bad, bad
        assert sim.state.step_count < 150
    return sim.state.step_count


C_TARGET = ((8, 2, 1), (8, 2, 7))  # the column of cells c's target stands in
C_YARD = ((1, 1, 1), (1, 1, 7))  # the column of cells of c's yard and pick-up poses
CASES = [
    # parts, cranes, arrival, outages, closures, claims per crane, bound
    ((C,), 1, {"c": 5}, (), (), {0: [(1, "c")]}, 5 + 11),  # claimed once due
    ((C,), 1, {}, ((0, 3, 7),), (), {0: [(1, "c")]}, 11 + 4),  # paused by a breakdown
    ((C,), 1, {}, ((0, 1, 4),), (), {0: [(1, "c")]}, 11 + 3),  # down right after the claim
    ((C,), 1, {"c": 2}, ((0, 1, 4),), (), {0: [(1, "c")]}, 4 + 11),  # down when it is due
    ((C, D), 2, {}, ((0, 1, 40),), (), {1: [(1, "c"), (1, "d")]}, 11 + 10),  # one does both
    ((C, D), 2, {"c": 20}, (), (), {0: [(1, "c")], 1: [(1, "d")]}, 20 + 11),
    # the beam waits for d, whose assembly waits for its crane; the other crane is free
    ((C_PREBUILT, D, B), 1, {}, ((0, 9, 12),), (), {0: [(1, "d"), (1, "b")]}, 13 + 7),
    ((C_PREBUILT, D, B), 2, {}, ((0, 9, 12),), (), {1: [(1, "d"), (1, "b")]}, 10 + 7),
    ((C_PREBUILT, D, B), 2, {}, ((0, 9, 12), (1, 1, 40)), (), {0: [(1, "d"), (1, "b")]}, 20),
    # c's target closed until 20: the move into it is made at 20 at the soonest
    ((C,), 1, {}, (), ((C_TARGET, 0, 20),), {0: [(1, "c")]}, 20 + 1 + 1),
    ((C,), 1, {}, (), ((C_TARGET, 0, 5),), {0: [(1, "c")]}, 11),  # open again in time
    ((C,), 1, {}, (), ((C_YARD, 0, 8),), {0: [(1, "c")]}, 8 + 11),  # no lift while closed
    ((C,), 1, {"c": 3}, ((0, 9, 12),), ((C_YARD, 0, 8),), {0: [(1, "c")]}, 8 + 11 + 3),
    # c cannot arrive before 21, so its 11 steps of work begin at 11 at the soonest, and d is
    # due at 15: one crane needs 32 (c first, hovering until its target opens, then d; d
    # first takes 36); without counting c's work back from its arrival the floor was 26
    ((C, D), 1, {"d": 15}, (), ((C_TARGET, 0, 20),), {0: [(1, "c"), (1, "d")]}, 22 + 10),
]


@pytest.mark.parametrize(
    ("parts", "n", "arrival", "outages", "closures", "claims", "expected"), CASES
)
def test_the_bound_knows_the_schedule_and_a_play_attains_it(
    parts, n, arrival, outages, closures, claims, expected
):
    scn = scenario(*parts)
    events = schedule(scn, arrival, outages, closures)
    result = lower_bound(scn, n, events=events, time_limit=10)
    assert result.optimal and result.value == expected, result
    assert play(scn, n, events, claims) == expected
    assert lower_bound(scn, n, time_limit=10).value <= expected  # the static bound is lower


def test_a_schedule_without_events_gives_the_static_model():
    scn = scenario(C, D)
    tasks = task_options(scn, 2, 0, schedule(scn))
    assert not tasks.has_events and {o.crane for o in tasks.options} == {None}
    late = task_options(scn, 2, 0, schedule(scn, outages=((1, 5, 9),)))
    assert late.has_events and {o.crane for o in late.options} == {0, 1}  # not interchangeable


@pytest.mark.parametrize("level", ["low", "high"])
def test_the_schedule_is_the_one_the_environment_draws(level):
    scn = multicrane.load_scenario("e4s2")
    env = multicrane.parallel_env(scn, n_cranes=3, events=level)
    for seed in (0, 3):
        env.reset(seed=seed)
        drawn = env.unwrapped.sim.schedule if hasattr(env, "unwrapped") else env.sim.schedule
        tasks = task_options(scn, 3, seed, level)
        due = {c: int(drawn.arrival[c]) for c in tasks.comps}
        assert tasks.release == due
        for k in range(3):
            assert tasks.outages[k] == tuple(sorted((o.start, o.end) for o in drawn.outages
                                                    if o.crane == k))  # fmt: skip


# -- never above a planner's makespan -----------------------------------------------------------

SITES = [  # family, generator seed, parameters, cranes, events level
    ("frame", 11, {"bays_x": 2, "bays_y": 1, "storeys": 1}, 2, "high"),
    ("hall", 12, {"bays_x": 2, "bays_y": 1}, 3, "low"),
    ("tower", 13, {"storeys": 2}, 2, "high"),
    ("frame", 14, {"bays_x": 1, "bays_y": 1, "storeys": 2, "reach": True}, 2, "high"),
    ("frame", 15, {"bays_x": 2, "bays_y": 1, "storeys": 1, "reach": True}, 3, None),
    ("hall", 16, {"bays_x": 1, "bays_y": 1}, 1, "high"),
]


@pytest.mark.parametrize(("family", "gen_seed", "params", "n", "level"), SITES)
def test_the_bound_never_exceeds_a_planners_makespan(family, gen_seed, params, n, level):
    scn = generate(family, gen_seed, random_start=False, obstacles=1, cranes=n, **params)
    for seed in (0, 1):
        bound = lower_bound(scn, n, seed, time_limit=2, workers=1, events=level)
        static = lower_bound(scn, n, seed, time_limit=2, workers=1)
        if level is not None and static.optimal and bound.optimal:
            assert bound.value >= static.value
        for planner in ("prioritized", "greedy"):
            env = multicrane.parallel_env(scn, n_cranes=n, events=level)
            m = run_episode(env, policies.make(planner, env, seed=seed), seed=seed)
            if m["success"]:
                assert bound.value <= m["makespan"], (planner, seed, bound, m["makespan"])


@pytest.mark.long
@pytest.mark.parametrize("gen_seed", range(20, 36))
def test_the_bound_never_exceeds_a_planners_makespan_on_many_sites(gen_seed):
    family = ("frame", "hall", "tower")[gen_seed % 3]
    n, level = 1 + gen_seed % 4, ("low", "high", None)[gen_seed % 3 - 1]
    params = {"reach": gen_seed % 5 == 0}
    test_the_bound_never_exceeds_a_planners_makespan(family, gen_seed, params, n, level)
