"""Site events (``multicrane.sim.events``): rules on hand-built states, determinism, invariants.

The rule tests use the micro site of ``tests/sim/test_rules.py`` (two columns in the yard, a beam
on both column targets) with a schedule written by hand; the rest use the shipped scenarios
with the presets and an everything-on spec.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import SCENARIOS, random_masked_actions, reach_skip, same
from hypothesis import given, settings
from hypothesis import strategies as st
from test_rules import C1, C2, micro_site

from multicrane.core.codes import CLAIM_BASE, WAIT, EventType, Move, SiteEventType, Status
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.envs.observation import Observer
from multicrane.scenario.loader import load_scenario, parse_scenario
from multicrane.sim.events import (
    EventSchedule,
    EventSpec,
    FixedClosure,
    Outage,
    closure,
    draw_schedule,
    preset,
)
from multicrane.sim.simulator import Simulator

ALL_ON = EventSpec(
    late_fraction=0.5, delay=(1, 30), breakdown_rate=0.05, breakdown_duration=(2, 8),
    closures=(FixedClosure(((0, 0, 1), (1, 1, 3)), 3, 20),),
    closure_rate=0.05, closure_size=(1, 3), closure_duration=(2, 10),
)  # fmt: skip


def make(arrival=(0, 0, 0), outages=(), closures=(), n_cranes=None, **site) -> Simulator:
    """The micro site with a hand-written schedule: closures as ((lo, hi), start, end)."""
    sim = Simulator(parse_scenario(micro_site(**site), "micro.toml"), n_cranes, events=EventSpec())
    sched = EventSchedule(
        np.array(arrival, dtype=np.int64),
        [Outage(*o) for o in outages],
        [closure(sim.site, box, s, e) for box, s, e in closures],
    )
    sim.reset(np.random.default_rng(0), schedule=sched)
    return sim


def cells(sim: Simulator, comp: int) -> list[tuple[int, int, int]]:
    return [sim.site.cell(j) for j in sim.state.cells[comp]]


def types(out) -> list[EventType]:
    return [e.type for e in out.events]


# -- deliveries ------------------------------------------------------------------------------


def test_undelivered_component_is_off_site_and_not_claimable():
    sim = make(arrival=(3, 0, 0))
    assert not sim.delivered(C1) and sim.delivered(C2)
    assert not any(sim.state.occ[j] == C1 + 1 for j in sim.state.cells[C1])
    assert C1 not in sim.claimable_components()
    assert sim.action_masks()[0][CLAIM_BASE + C1] == 0
    out = sim.step([CLAIM_BASE + C1])
    assert types(out) == [EventType.ILLEGAL] and sim.state.status[C1] == Status.INITIAL
    sim.step([WAIT])
    out = sim.step([WAIT])  # time 3: due, its yard cells are free
    assert [(e.type, e.component) for e in out.site_events] == [(SiteEventType.DELIVERED, C1)]
    assert sim.delivered(C1) and C1 in sim.claimable_components()
    assert all(sim.state.occ[j] == C1 + 1 for j in sim.state.cells[C1])


@pytest.mark.parametrize("what", ["occupied", "closed"])
def test_delivery_waits_while_its_cells_are_taken_or_closed(what):
    if what == "occupied":
        # c2 is lifted to (2, 1, 2..5), moved x-1 and down onto c1's yard cell (1, 1, 1).
        sim = make(arrival=(3, 0, 0))
        sim.step([CLAIM_BASE + C2])
        sim.step([Move.X_MINUS])
        out = sim.step([Move.DOWN])  # time 3: c1 is due, but (1, 1, 1) is c2's
        assert (1, 1, 1) in cells(sim, C2)
        after = [Move.UP]
    else:
        sim = make(arrival=(2, 0, 0), closures=[(((1, 4, 1), (1, 4, 1)), 0, 4)])
        sim.step([WAIT])
        out = sim.step([WAIT])  # time 2: due, but a cell is closed until 4
        after = [WAIT, WAIT]
    assert not sim.delivered(C1) and not out.site_events
    for a in after:
        out = sim.step([a])
    assert sim.delivered(C1)
    assert SiteEventType.DELIVERED in [e.type for e in out.site_events]


# -- breakdowns ------------------------------------------------------------------------------


def test_down_crane_may_only_wait_and_comes_back():
    sim = make(outages=[(0, 0, 2)])
    assert not sim.crane_up(0)
    mask = sim.action_masks()[0]
    assert mask.sum() == 1 and mask[WAIT] == 1
    out = sim.step([CLAIM_BASE + C1])
    assert types(out) == [EventType.ILLEGAL] and sim.state.held[0] == -1
    out = sim.step([WAIT])
    assert [e.type for e in out.site_events] == [SiteEventType.CRANE_UP]
    assert sim.crane_up(0) and sim.action_masks()[0][CLAIM_BASE + C1] == 1


def test_held_component_stays_held_and_blocks_while_its_crane_is_down():
    sim = make(outages=[(0, 2, 4)], n_cranes=2, cranes=2)
    sim.step([CLAIM_BASE + C1, WAIT], order=[0, 1])  # time 1: lifted
    out = sim.step([WAIT, WAIT])  # time 2: crane 0 down
    assert [(e.type, e.crane) for e in out.site_events] == [(SiteEventType.CRANE_DOWN, 0)]
    before = cells(sim, C1)
    out = sim.step([Move.X_PLUS, CLAIM_BASE + C1], order=[0, 1])
    assert cells(sim, C1) == before and sim.state.holder[C1] == 0 and sim.state.held[0] == C1
    assert sim.state.status[C1] == Status.IN_TRANSIT
    assert EventType.ILLEGAL in types(out) and sim.state.held[1] == -1
    sim.step([WAIT, WAIT])  # time 4: up again
    out = sim.step([Move.X_PLUS, WAIT])
    assert cells(sim, C1) != before


def test_assembly_pauses_while_the_crane_is_down():
    sim = make(outages=[(0, 8, 11)], assembly_steps=3)
    plan = [CLAIM_BASE + C1] + [Move.X_PLUS] * 4 + [Move.Y_PLUS, Move.DOWN, 7]
    for a in plan:
        sim.step([a])  # the assemble action at time 7 -> 8 starts it: 2 steps left
    assert sim.state.assembling[0] == 2 and not sim.crane_up(0)
    for _ in range(3):  # times 9, 10, 11: down until 11
        sim.step([WAIT])
    assert sim.state.assembling[0] == 2 and sim.state.status[C1] == Status.ARRIVED
    sim.step([WAIT])
    sim.step([WAIT])
    assert sim.state.status[C1] == Status.ASSEMBLED


# -- closed zones ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    "box, move",
    [
        (((2, 1, 2), (2, 1, 2)), Move.X_PLUS),  # the cell it would enter
        (((1, 2, 5), (1, 2, 5)), Move.Y_PLUS),
        (((1, 1, 1), (1, 1, 1)), Move.DOWN),
    ],
)
def test_closed_cell_refuses_a_move_into_it(box, move):
    sim = make(closures=[(box, 2, 9)])
    sim.step([CLAIM_BASE + C1])  # lifted to (1, 1, 2..5)
    sim.step([WAIT])  # time 2: closed
    assert sim.action_masks()[0][move] == 0 and sim.action_masks()[0][Move.UP] == 1
    before = cells(sim, C1)
    out = sim.step([move])
    assert cells(sim, C1) == before and types(out) == [EventType.BLOCKED]


def test_component_inside_a_closed_zone_cannot_move():
    sim = make(closures=[(((1, 1, 5), (1, 1, 5)), 2, 9)])
    sim.step([CLAIM_BASE + C1])
    sim.step([WAIT])
    assert sim.action_masks()[0][:6].sum() == 0
    before = cells(sim, C1)
    sim.step([Move.X_PLUS])
    assert cells(sim, C1) == before


@pytest.mark.parametrize(
    "box", [((1, 1, 3), (1, 1, 3)), ((1, 3, 1), (1, 3, 1))]  # its pick-up pose; its yard cells
)
def test_closed_zone_refuses_a_lift(box):
    sim = make(closures=[(box, 0, 5)])
    assert C1 not in sim.claimable_components()
    out = sim.step([CLAIM_BASE + C1])
    assert types(out) == [EventType.LIFT_BLOCKED] and sim.state.status[C1] == Status.INITIAL


def test_target_with_a_closed_cell_is_not_ready_until_it_opens():
    sim = make(closures=[(((5, 2, 4), (5, 2, 4)), 0, 2)])
    assert not sim.target_ready[C1] and sim.target_ready[C2]
    sim.step([WAIT])
    out = sim.step([WAIT])
    assert [e.type for e in out.site_events] == [SiteEventType.ZONE_OPENED]
    assert sim.target_ready[C1] and not sim.closed.any()


# -- the schedule ----------------------------------------------------------------------------


def test_schedule_is_drawn_from_the_generator_and_round_trips():
    sc = load_scenario("e3s2")
    sim = Simulator(sc, events=preset("high", sc))
    prebuilt = np.zeros(sim.site.n_components, dtype=bool)
    a = draw_schedule(ALL_ON, sim.site, prebuilt, 2, 500, np.random.default_rng(5))
    b = draw_schedule(ALL_ON, sim.site, prebuilt, 2, 500, np.random.default_rng(5))
    assert a.equals(b) and a.outages and a.closures and (a.arrival > 0).any()
    assert all(1 <= o.start < o.end for o in a.outages)
    assert EventSchedule.from_json(a.to_json(), sim.site).equals(a)
    assert preset("none", sc) == EventSpec()


@pytest.mark.parametrize("bad", ["medium", 3])
def test_unknown_level_is_refused(bad):
    with pytest.raises(ValueError, match="events"):
        MultiCraneEnv("e2s2", events=bad)


# -- environments: determinism, invariants, spaces --------------------------------------------


def play(env: MultiCraneEnv, seed: int, steps: int, check=None) -> list:
    rng = np.random.default_rng(seed + 1)
    sim = env.sim
    if check is not None:  # checked after every simulated step (several per task-level step)
        step = Simulator.step.__get__(sim)  # the class's: a reused env is wrapped once

        def checked(actions, order=None):
            before = sim.snapshot(), sim.closed, list(sim._down)
            out = step(actions, order)
            check(sim, *before)
            return out

        sim.step = checked
    obs, _ = env.reset(seed=seed)
    trace = [env.sim.schedule.to_json()]
    for _ in range(steps):
        if not env.agents:
            break
        obs, rewards, _, _, infos = env.step(random_masked_actions(obs, rng))
        first = obs[env.possible_agents[0]]
        trace.append((first["observation"].copy(), rewards, [e for e in env.last_site_events]))
    return trace


@pytest.mark.parametrize("decisions", ["motion", "task"])
def test_same_seed_same_episode_with_every_event_on(decisions):
    runs = [play(MultiCraneEnv("e3s2", 2, decisions=decisions, events=ALL_ON), 3, 60)
            for _ in range(2)]  # fmt: skip
    assert same(runs[0], runs[1])
    kinds = {e.type for _, _, evs in runs[0][1:] for e in evs}
    assert len(kinds) >= 3, kinds


def check_invariants(sim: Simulator, snap, closed_before, down_before) -> None:
    """No overlap, nothing lost, states only forward; closed cells and down cranes obeyed."""
    st = sim.state
    occ = st.occ
    seen = np.zeros(sim.site.n_components, dtype=np.int64)
    for c in range(sim.site.n_components):
        assert st.status[c] >= snap.status[c]  # only forward
        assert st.delivered[c] >= snap.delivered[c]
        if st.delivered[c]:
            assert all(occ[j] == c + 1 for j in st.cells[c]), f"component {c} lost"
            seen[c] = len(st.cells[c])
        else:
            assert st.status[c] == Status.INITIAL and st.holder[c] == -1
        moved = st.cells[c] != snap.cells[c]
        if moved and snap.delivered[c]:
            assert not closed_before[st.cells[c]].any(), "entered a closed cell"
            assert not closed_before[snap.cells[c]].any(), "left a closed zone"
            crane = int(st.holder[c]) if st.holder[c] >= 0 else int(snap.holder[c])
            assert crane < 0 or not down_before[crane], "a down crane moved its load"
    filled = occ > 0
    assert filled.sum() == seen.sum()  # no overlap: each cell holds one component


def fresh_observations(env: MultiCraneEnv) -> np.ndarray:
    """The motion observation built from scratch (the env's is kept incrementally)."""
    fresh = Observer(env.sim)
    fresh.reset(env.step_limit)
    fresh.update(set(), env.sim.claimable_components(), full=True)
    return fresh.observe_all().reshape(-1)


@pytest.mark.parametrize("decisions", ["motion", "task", "auto"])
def test_invariants_under_random_play_with_every_event_on(decisions):
    for seed in range(2):
        env = events_env("e3s2", decisions, ALL_ON)
        play(env, seed, 150, check_invariants)
        if decisions == "motion":
            assert np.array_equal(env.state(), fresh_observations(env))


def events_env(name: str, decisions: str, events, n_cranes: int | None = 2) -> MultiCraneEnv:
    if decisions == "auto":
        return MultiCraneEnv(name, 1, auto=True, events=events)
    return MultiCraneEnv(name, n_cranes, decisions=decisions, events=events)


@pytest.mark.fuzz
@pytest.mark.parametrize("events", ["high", ALL_ON], ids=["high", "all-on"])
@pytest.mark.parametrize("decisions", ["motion", "task", "auto"])
@pytest.mark.parametrize("name", SCENARIOS)
def test_invariants_long_random_play_with_events(name, decisions, events):
    """The large runs, only with ``-m fuzz`` (about 100 s): long random play on every
    shipped scenario, both decision levels and the automatic mode."""
    if (why := reach_skip(name, 1 if decisions == "auto" else None)) is not None:
        pytest.skip(why)
    env = events_env(name, decisions, events, n_cranes=None)
    for seed in range(3):
        play(env, seed, 600, check_invariants)
        if decisions == "motion":
            assert np.array_equal(env.state(), fresh_observations(env))


def test_parallel_api_with_events():
    from pettingzoo.test import parallel_api_test

    parallel_api_test(MultiCraneEnv("e2s2", 2, events="high"), num_cycles=60)


def test_spaces_grow_only_with_events():
    plain = MultiCraneEnv("e2s2", 2)
    none = MultiCraneEnv("e2s2", 2, events="none")
    C, N = plain.sim.site.n_components, 2
    X, Y, _ = plain.scenario.size
    size = plain.observation_layout.size
    assert none.observation_layout.size == size + C + N + X * Y
    obs, infos = none.reset(seed=0)
    part = none.observation_layout.split(obs["crane_0"]["observation"])
    assert part["delivered"].all() and part["available"].all() and not part["closed"].any()
    assert "site_event_counts" in infos["crane_0"]
    assert "site_event_counts" not in plain.reset(seed=0)[1]["crane_0"]


# -- the [events] table ------------------------------------------------------------------------

EVENTS_OK = """
[events]
late_fraction = 0.5
delay = [2, 9]
breakdown_rate = 0.01
breakdown_duration = [3, 6]
closure_rate = 0.02
closure_size = [1, 2]
closure_duration = [4, 8]
arrivals = { b1 = 12 }
[[events.closures]]
min = [0, 0, 1]
max = [1, 1, 6]
start = 2
end = 10
"""


def test_events_table_is_read_into_a_spec():
    spec = parse_scenario(micro_site(extra=EVENTS_OK), "micro.toml").events
    assert spec == EventSpec(
        arrivals=(0, 0, 12), late_fraction=0.5, delay=(2, 9), breakdown_rate=0.01,
        breakdown_duration=(3, 6), closures=(FixedClosure(((0, 0, 1), (1, 1, 6)), 2, 10),),
        closure_rate=0.02, closure_size=(1, 2), closure_duration=(4, 8),
    )  # fmt: skip
    assert parse_scenario(micro_site(), "micro.toml").events is None
    env = MultiCraneEnv(parse_scenario(micro_site(extra=EVENTS_OK), "micro.toml"))
    env.reset(seed=0)
    assert env.sim.schedule is not None and env.sim.schedule.arrival[2] >= 12


@pytest.mark.parametrize(
    "text, key, value",
    [
        ("late_fraction = 1.5", "events.late_fraction", "1.5"),
        ("delay = [5, 2]", "events.delay", "[5, 2]"),
        ("breakdown_duration = [0, 3]", "events.breakdown_duration", "[0, 3]"),
        ('closure_rate = "often"', "events.closure_rate", "'often'"),
        ("arrivals = { zz = 3 }", "events.arrivals.zz", "3"),
        ("arrivals = { c1 = -1 }", "events.arrivals.c1", "-1"),
        ("surprise = 1", "events.surprise", "1"),
        ("[[events.closures]]\nmin = [0, 0, 1]\nmax = [9, 0, 1]\nstart = 0\nend = 3",
         "events.closures[0].max", "[9, 0, 1]"),
        ("[[events.closures]]\nmin = [0, 0, 1]\nmax = [1, 1, 1]\nstart = 4\nend = 4",
         "events.closures[0].end", "4"),
    ],
)  # fmt: skip
def test_events_table_errors_name_file_key_and_value(text, key, value):
    from multicrane.core.schema import ScenarioError

    with pytest.raises(ScenarioError) as err:
        parse_scenario(micro_site(extra="[events]\n" + text), "micro.toml")
    msg = str(err.value)
    assert msg.startswith("micro.toml: ") and key in msg and value in msg, msg


# -- records -------------------------------------------------------------------------------------


@pytest.mark.parametrize("decisions", ["motion", "task"])
def test_record_with_events_resimulates_exactly(decisions, tmp_path):
    from multicrane.replay.record import EpisodeRecord, record_episode, resimulate
    from policies.random_policy import RandomPolicy

    env = MultiCraneEnv("e2s2", 2, decisions=decisions, events=ALL_ON, max_steps=120)
    rec = record_episode(env, RandomPolicy(seed=1), seed=4)
    assert rec.schedule and rec.to_dict()["schedule"] == env.sim.schedule.to_json()
    loaded = EpisodeRecord.load(rec.save(tmp_path / "ep.json.gz"))
    replay, _, _ = resimulate(loaded)  # raises on any difference
    assert replay.sim.schedule.equals(env.sim.schedule)
    plain = record_episode(MultiCraneEnv("e2s2", 2, max_steps=30), RandomPolicy(seed=1), seed=4)
    assert "schedule" not in plain.to_dict()
    resimulate(EpisodeRecord.from_dict(plain.to_dict()))


def test_events_table_round_trips_through_scenario_toml():
    from multicrane.scenario.writer import to_toml

    s = parse_scenario(micro_site(extra=EVENTS_OK), "micro.toml")
    back = parse_scenario(to_toml(s), "micro.toml")
    assert back.events == s.events and back.components == s.components


def test_task_level_parallel_api_with_events():
    from pettingzoo.test import parallel_api_test

    parallel_api_test(MultiCraneEnv("e2s2", 2, decisions="task", events="high"), num_cycles=30)


@pytest.mark.parametrize("decisions", ["motion", "task"])
def test_observation_shows_nothing_of_the_future(decisions):
    """Two schedules that differ only after time 6 give the same observations until then."""
    env = MultiCraneEnv("e3s2", 2, decisions=decisions, events="none")
    C = env.sim.site.n_components
    seen = []
    for late, start in ((8, 7), (40, 30)):
        arrival = np.zeros(C, dtype=np.int64)
        arrival[[1, 3]] = late
        shut = closure(env.sim.site, ((0, 0, 1), (2, 2, 2)), start, 50)
        sched = EventSchedule(arrival, [Outage(0, start, start + 5)], [shut])
        obs, _ = env.reset(seed=2, options={"schedule": sched})
        steps = [obs]
        while env.sim.state.step_count < 6:
            obs, *_ = env.step(dict.fromkeys(env.agents, 0 if decisions == "task" else WAIT))
            steps.append(obs)
        seen.append(steps)
    assert same(seen[0], seen[1])


@settings(max_examples=60, deadline=None, derandomize=True, database=None)
@given(
    st.floats(0, 1), st.tuples(st.integers(0, 30), st.integers(0, 30)).map(sorted),
    st.floats(0, 0.3), st.tuples(st.integers(1, 20), st.integers(1, 20)).map(sorted),
    st.floats(0, 0.3), st.tuples(st.integers(1, 9), st.integers(1, 9)).map(sorted),
    st.integers(0, 2**32),
)  # fmt: skip
def test_drawn_schedules_keep_their_spec(late, delay, rate, duration, c_rate, size, seed):
    """Property: whatever the spec, the schedule keeps its ranges, never overlaps one crane's
    outages, starts nothing at 0 or past the horizon, and closes only cells of the site."""
    spec = EventSpec(late_fraction=late, delay=tuple(delay), breakdown_rate=rate,
                     breakdown_duration=tuple(duration), closure_rate=c_rate,
                     closure_size=tuple(size), closure_duration=tuple(duration))  # fmt: skip
    site = MICRO.site
    prebuilt = np.array([False, False, True])
    s = draw_schedule(spec, site, prebuilt, 2, 200, np.random.default_rng(seed))
    assert s.arrival[2] == 0 and ((s.arrival == 0) | (s.arrival >= delay[0])).all()
    assert (s.arrival <= delay[1]).all()
    for k in range(2):
        mine = sorted(o for o in s.outages if o.crane == k)
        assert all(1 <= o.start < 200 and duration[0] <= o.end - o.start <= duration[1]
                   for o in mine)  # fmt: skip
        assert all(a.end <= b.start for a, b in zip(mine, mine[1:], strict=False))
    for c in s.closures:
        assert 1 <= c.start < 200 and duration[0] <= c.end - c.start <= duration[1]
        assert c.cells and all(site.static[j] == 0 for j in c.cells)


MICRO = Simulator(parse_scenario(micro_site(), "micro.toml"))
