"""Planners on sites with events: the replanning planner, the static plan, the benchmark.

Without events both planners are the static prioritized planner (same makespans). With events
(``MultiCraneEnv(events=...)``, docs/uncertainty.md) a hand-built schedule forces a breakdown
and a closed zone on a small site: the replanning planner routes around them and reassigns,
the static plan waits and takes longer; both finish every built-in scenario under ``low`` and
``high`` events for a few seeds (more seeds under the ``fuzz`` marker).
"""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest

import multicrane
import policies
from multicrane.episodes.rollout import run_episode
from multicrane.reports.uncertainty import Cell, episode_seeds, markdown_table


def play(name: str, scenario: str, n: int, seed: int, **env_options) -> tuple[dict, object]:
    env = multicrane.parallel_env(scenario, n_cranes=n, **env_options)
    policy = policies.make(name, env, seed=seed)
    return run_episode(env, policy, seed=seed), policy


@pytest.mark.parametrize(("scenario", "n"), [("e2s2", 2), ("e3s2", 3), ("hall-4c", 4)])
def test_static_plan_is_the_prioritized_episode_without_events(scenario, n):
    """On an undisturbed site the static plan's clock never stops: the same makespan."""
    for seed in (0, 1):
        static, policy = play("static-plan", scenario, n, seed)
        planned, _ = play("prioritized", scenario, n, seed)
        assert static["makespan"] == planned["makespan"] is not None
        assert policy.stats["waits"] == 0 and policy.stats["fallback"] == 0
        assert policy.stats["plan_steps"] == static["makespan"]


def test_replanning_is_the_prioritized_planner_without_events():
    a, _ = play("replanning", "e3s2", 2, 0)
    b, pb = play("prioritized", "e3s2", 2, 0)
    assert a["makespan"] == b["makespan"]
    assert "event_replans" not in pb.stats  # no events, no event counters


def test_static_plan_refuses_task_decisions():
    env = multicrane.parallel_env("e2s2", n_cranes=2, decisions="task")
    with pytest.raises(policies.PolicyError, match="'static-plan' drives motion decisions"):
        policies.make("static-plan", env, seed=0)


def test_new_names_are_listed_for_the_multi_agent_mode():
    assert {"replanning", "static-plan"} <= set(policies.names(False))


# -- the benchmark's arithmetic -----------------------------------------------------------------


def test_episode_seeds_and_refusals():
    assert episode_seeds(2, 2) == [0, 1, 1000, 1001]
    with pytest.raises(ValueError, match="at least 1"):
        episode_seeds(0, 1)


def test_cell_summary_and_table():
    cell = Cell("e2s2", 2, "high", "static-plan", [0, 1, 2], [30, 34, None])
    assert cell.completion == pytest.approx(2 / 3)
    assert cell.mean == 32.0
    lo, hi = cell.ci
    assert lo < 32.0 < hi
    json.dumps(cell.as_dict())
    table = markdown_table([cell, Cell("e2s2", 2, "high", "replanning", [0], [31])], [])
    assert "| e2s2 | 2 | high | 32.0 [" in table
    assert "(67%)" in table and "31.0 (100%)" in table


# -- what a planner sees of the events: hand-built states ---------------------------------------


def fake_sim(status, holder, cells, down=(), closed=(), undelivered=(), schedule=True):
    """The few fields ``multicrane.sim.event_knowledge`` reads, for table-driven cases."""
    n = len(status)
    mask = np.zeros(64, dtype=bool)
    mask[list(closed)] = True
    return SimpleNamespace(
        schedule=object() if schedule else None,
        n_cranes=2,
        crane_up=lambda k: k not in down,
        delivered=lambda c: c not in undelivered,
        closed=mask,
        site=SimpleNamespace(n_components=n),
        state=SimpleNamespace(status=np.array(status), holder=np.array(holder), cells=cells),
    )


# status: 0 initial, 1 in transit, 2 arrived, 3 assembled; holder -1: none
FROZEN_CASES = [
    ("nothing happens", dict(), set()),
    ("held by a crane that is down", dict(down={1}), {1}),
    ("the crane of the other one is down", dict(down={0}), set()),
    ("a cell inside a closed zone", dict(closed={21}), {1}),
    ("a closed cell beside it", dict(closed={22}), set()),
    ("a closed yard cell: not in transit", dict(closed={10}), set()),
    ("arrived, its crane down: not in transit", dict(down={0, 1}), {1}),
]


@pytest.mark.parametrize(
    ("case", "events", "frozen"), FROZEN_CASES, ids=[c[0] for c in FROZEN_CASES]
)
def test_frozen_components(case, events, frozen):
    from multicrane.sim.event_knowledge import event_view, frozen_components

    # component 0 initial in the yard, 1 in transit held by crane 1, 2 arrived held by crane 0
    sim = fake_sim([0, 1, 2], [-1, 1, 0], [[10, 11], [20, 21], [30, 31]], **events)
    view = event_view(sim)
    assert frozen_components(sim, view) == frozen
    assert view.down == frozenset(events.get("down", ()))
    assert view.closed == tuple(sorted(events.get("closed", ())))


def test_event_view_without_events_and_quiet():
    from multicrane.sim.event_knowledge import event_view, frozen_components

    sim = fake_sim([1], [0], [[5]], down={0}, schedule=False)
    assert event_view(sim) is None and frozen_components(sim, None) == set()
    assert event_view(fake_sim([0], [-1], [[5]])).quiet
    late = event_view(fake_sim([0], [-1], [[5]], undelivered={0}))
    assert late.undelivered == {0} and not late.quiet


def test_closed_cells_are_reserved_for_ever_and_block_a_claim():
    """A closed zone over a component's pick-up pose: the carrier's table holds the closed
    cells from now on, and the component cannot be started; it can once the zone opens."""
    from multicrane.sim.events import EventSchedule, EventSpec, closure
    from multicrane.sim.simulator import Simulator
    from multicrane.tasks.carrier_events import CLOSED, EventCarrier
    from multicrane.tasks.reservations import INF

    scenario = multicrane.load_scenario("e3s2")
    sim = Simulator(scenario, 2, events=EventSpec())
    sim.reset(np.random.default_rng(0))
    comp = sim.claimable_components()[0]
    x, y, _ = sim.site.cell(sim.state.pickup[comp][0])
    zone = closure(sim.site, ((x, y, 1), (x, y, scenario.size[2])), 0, 3)
    schedule = EventSchedule(np.zeros(sim.site.n_components, dtype=np.int64), [], [zone])
    sim.reset(np.random.default_rng(0), start=sim.start, schedule=schedule)
    carrier = EventCarrier(sim)
    carrier.begin(0)
    table = carrier._fresh_table(0)
    assert all((0, INF, CLOSED) in table[j] for j in zone.cells)
    target = sim.site.compatible[comp][0]
    assert not carrier.try_start(0, comp, target)
    for _ in range(3):
        sim.step([6, 6])  # wait until the zone opens at step 3
    carrier.begin(3)
    assert not sim.closed.any()
    assert any(carrier.try_start(0, comp, t) for t in sim.ready_targets(comp))


# -- a hand-built disruption: a breakdown and a closed zone --------------------------------------


def drive(sim, policy, limit: int) -> list[dict]:
    """Play ``policy`` on ``sim`` to the end (or ``limit`` steps) with the simulator's masks;
    one row per step: held components, cells, statuses and the cranes that assembled."""
    rng = np.random.default_rng(0)
    agents = [f"crane_{k}" for k in range(sim.n_cranes)]
    rows = []
    while sim.state.n_assembled < sim.site.n_components and sim.state.step_count < limit:
        masks = sim.action_masks()
        joint = policy({a: {"action_mask": masks[k]} for k, a in enumerate(agents)})
        actions = [int(joint[a]) for a in agents]
        assert all(masks[k][a] for k, a in enumerate(actions)), "a planner sent a masked action"
        out = sim.step(actions, rng.permutation(sim.n_cranes).tolist())
        st = sim.state
        rows.append({
            "t": st.step_count, "held": list(st.held), "status": st.status.copy(),
            "cells": [[sim.site.cell(j) for j in c] for c in st.cells],
            "assembled_by": list(out.assembled_by),
        })  # fmt: skip
    return rows


def disrupted(name: str):
    """e3s2 with 2 cranes: crane 0 down during [6, 50), the strip x 5..10, y 7 (every height,
    between the yard and the building) closed during [2, 40)."""
    from multicrane.sim.events import EventSchedule, EventSpec, Outage, closure
    from multicrane.sim.simulator import Simulator
    from policies.prioritized import PrioritizedPlanner
    from policies.static_plan import StaticPlan

    scenario = multicrane.load_scenario("e3s2")
    sim = Simulator(scenario, 2, events=EventSpec())
    n = sim.site.n_components
    zone = closure(sim.site, ((5, 7, 1), (10, 7, scenario.size[2])), 2, 40)
    schedule = EventSchedule(np.zeros(n, dtype=np.int64), [Outage(0, 6, 50)], [zone])
    sim.reset(np.random.default_rng(0), schedule=schedule)
    env = SimpleNamespace(sim=sim, scenario=scenario, possible_agents=["crane_0", "crane_1"],
                          step_limit=scenario.step_limit, decisions="motion")  # fmt: skip
    policy = PrioritizedPlanner(env) if name == "replanning" else StaticPlan(env)
    rows = drive(sim, policy, scenario.step_limit)
    return sim, policy, rows, set(zone.cells)


def test_replanning_goes_on_around_a_breakdown_and_a_closed_zone():
    sim, planner, rows, closed = disrupted("replanning")
    _, static, static_rows, _ = disrupted("static-plan")
    n = sim.site.n_components
    # Both finish; the replanning planner sooner, the static plan after waiting.
    assert rows[-1]["status"].tolist() == [3] * n
    assert static_rows[-1]["status"].tolist() == [3] * n
    assert len(rows) < len(static_rows)
    assert static.stats["waits"] >= 44 and static.stats["fallback"] == 0
    assert planner.stats["event_replans"] >= 2 and planner.stats["fallbacks"] == 0
    during = [r for r in rows if 6 <= r["t"] < 50]
    # The broken crane keeps its component where it is for the whole outage...
    held = during[0]["held"][0]
    assert held >= 0
    assert all(r["held"][0] == held and r["cells"][held] == during[0]["cells"][held]
               for r in during)  # fmt: skip
    # ...while the other crane carries on: its work is reassigned, nothing waits for crane 0.
    assert sum(r["assembled_by"].count(1) for r in during) >= 2
    assert not any(r["assembled_by"] for r in static_rows if r["t"] < 50)
    # Closed cells are never entered, and crane 1 routes around the strip while it is closed.
    for r in rows + static_rows:
        if 2 <= r["t"] < 40:
            assert not any(sim.site.lin(*xyz) in closed for c in r["cells"] for xyz in c)
    around = [
        r["t"] for r in rows if 2 <= r["t"] < 40 and r["held"][1] >= 0
        and any(y == 7 and not 5 <= x <= 10 for x, y, _ in r["cells"][r["held"][1]])
    ]  # fmt: skip
    assert around, "crane 1 never crossed the closed row beside the strip"


def test_a_frozen_component_keeps_its_target_until_it_is_planned_again():
    """Crane 0 breaks down carrying a component: while it is frozen, the target of its dropped
    plan stays taken (no other component is planned to it or fills it), and it is the target
    the component is planned to once the crane is back. Releasing that target once stalled a
    task-level episode: another beam took it, and the frozen beam, left with a target that
    waited on the column it hung over, blocked it until the step limit (docs/uncertainty.md)."""
    from multicrane.sim.events import EventSchedule, EventSpec, Outage
    from multicrane.sim.simulator import Simulator
    from policies.prioritized import PrioritizedPlanner

    scenario = multicrane.load_scenario("e3s2")
    sim = Simulator(scenario, 2, events=EventSpec())
    n = sim.site.n_components
    schedule = EventSchedule(np.zeros(n, dtype=np.int64), [Outage(0, 6, 50)], [])
    sim.reset(np.random.default_rng(0), schedule=schedule)
    env = SimpleNamespace(sim=sim, scenario=scenario, possible_agents=["crane_0", "crane_1"],
                          step_limit=scenario.step_limit, decisions="motion")  # fmt: skip
    planner = PrioritizedPlanner(env)
    carrier = planner.carrier
    rng = np.random.default_rng(0)
    frozen = kept = None
    while sim.state.n_assembled < n and sim.state.step_count < scenario.step_limit:
        t = sim.state.step_count
        if t == 5:  # the last round before the outage: crane 0's component has a plan
            frozen = int(sim.state.held[0])
            kept = carrier.plans[frozen].target
        masks = sim.action_masks()
        joint = planner({f"crane_{k}": {"action_mask": masks[k]} for k in range(2)})
        if 6 <= t < 50:
            assert frozen in carrier._frozen and kept in carrier.taken_targets()
            assert all(p.target != kept for c, p in carrier.plans.items() if c != frozen)
            assert sim.state.filled_by[kept] in (-1, frozen)
        sim.step([int(joint[f"crane_{k}"]) for k in range(2)], rng.permutation(2).tolist())
    assert frozen is not None and frozen >= 0
    assert sim.state.n_assembled == n
    assert sim.state.filled_by[kept] == frozen


# -- every built-in scenario under low and high events --------------------------------------------


def _settings() -> list[tuple[str, int]]:
    out = []
    for name in multicrane.scenario_names():
        s = multicrane.load_scenario(name)
        out.append((name, s.cranes))
        if not s.crane_specs and s.cranes > 1:
            out.append((name, 1))
    return out


def finishes(name: str, scenario: str, n: int, level: str, seed: int) -> dict:
    """An episode with a long step limit (events are drawn up to the scenario's own limit, so
    they end): the planner must finish, never send a masked action and never fall back."""
    limit = 5 * multicrane.load_scenario(scenario).step_limit
    env = multicrane.parallel_env(scenario, n_cranes=n, events=level, max_steps=limit)
    policy = policies.make(name, env, seed=seed)
    result = run_episode(env, policy, seed=seed)
    assert result["success"], (name, scenario, n, level, seed)
    assert result["failed_actions"] == 0
    assert policy.stats.get("fallback", 0) == 0 and policy.stats.get("fallbacks", 0) == 0
    return result


@pytest.mark.parametrize("level", ["low", "high"])
@pytest.mark.parametrize("name", ["replanning", "static-plan"])
def test_planners_finish_every_scenario_with_events(name, level):
    for scenario, n in _settings():
        finishes(name, scenario, n, level, seed=0)


@pytest.mark.fuzz
@pytest.mark.parametrize("level", ["low", "high"])
@pytest.mark.parametrize("name", ["replanning", "static-plan"])
def test_planners_finish_every_scenario_with_events_many_seeds(name, level):
    for scenario, n in _settings():
        for seed in range(1, 5):
            finishes(name, scenario, n, level, seed)


# -- replays show the events ----------------------------------------------------------------------


COLUMNS = {
    "/components": "Boxes3D:half_sizes",
    "/cranes/hooks": "Points3D:colors",
    "/site/closed": "Boxes3D:centers",
    "/events": "TextLog:text",
}


def test_replay_draws_deliveries_breakdowns_and_closures(tmp_path):
    rr = pytest.importorskip("rerun")
    from rerun.chunk import RrdReader

    from multicrane.replay import viewer
    from multicrane.replay.viewer_episode import HOOK_DOWN, HOOK_UP

    rr.set_strict_mode(True)
    env = multicrane.parallel_env("e3s2", n_cranes=2, events="high")
    seed = next(s for s in range(50) if _eventful(env, s))
    path = tmp_path / "events.rrd"
    policy = policies.make("replanning", env, seed=seed)
    record = viewer.record_and_save(env, policy, seed, path, "replanning")
    schedule = env.sim.schedule
    columns = _replay_columns(RrdReader, path)
    # The record re-simulates with its events, and its replay draws the same.
    viewer.record_to_rrd(record, tmp_path / "again.rrd")
    assert _replay_columns(RrdReader, tmp_path / "again.rrd") == columns
    # A late component is not drawn before its delivery (a zero box), and drawn after.
    late = int(np.argmax(schedule.arrival))
    halves = columns["/components"]
    assert halves[0][late] == [0.0, 0.0, 0.0]
    assert max(halves)  # the episode ran
    assert any(h[late] != [0.0, 0.0, 0.0] for h in halves.values())
    # A crane that is down has a red hook exactly while it is down.
    outage = schedule.outages[0]
    hooks = columns["/cranes/hooks"]
    assert hooks[outage.start][outage.crane] == HOOK_DOWN
    assert hooks[0][outage.crane] == HOOK_UP or outage.start == 0
    # Closed zones are drawn while closed, and not otherwise.
    zone = schedule.closures[0]
    closed = columns["/site/closed"]
    assert len(closed[zone.start]) >= 1
    open_steps = [t for t in closed if not schedule.closures_at(t)]
    assert all(closed[t] in ([], None) for t in open_steps)
    # The text log tells the site events.
    texts = " / ".join(t for row in columns["/events"].values() for t in row)
    for words in ("breaks down", "is back", "is delivered", "a zone closes"):
        assert words in texts, words


def _replay_columns(RrdReader, path) -> dict[str, dict[int, list]]:
    """Per entity of ``COLUMNS``: step -> that column's row."""
    columns: dict[str, dict[int, list]] = {}
    for chunk in RrdReader(path).stream().to_chunks():
        if chunk.is_static or chunk.entity_path not in COLUMNS:
            continue
        batch = chunk.to_record_batch()
        name = COLUMNS[chunk.entity_path]
        rows = columns.setdefault(chunk.entity_path, {})
        for t, row in zip(batch.column("step").to_pylist(), batch.column(name).to_pylist(),
                          strict=True):  # fmt: skip
            rows[t] = row
    return columns


def _eventful(env, seed: int) -> bool:
    env.reset(seed=seed)
    s = env.sim.schedule
    return (
        bool(s.outages)
        and bool(s.closures)
        and int(s.arrival.max()) > 0
        and (s.outages[0].start < 60 and s.closures[0].start < 60)
    )


# -- the command -------------------------------------------------------------------------------


def test_uncertainty_command_writes_results_table_and_plot(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    from multicrane.cli import main

    argv = ["uncertainty", "--scenarios", "e2s2:2", "--levels", "none", "high", "--seeds", "2",
            "--policies", "static-plan", "replanning", "--bound-time", "2", "--out",
            str(tmp_path)]  # fmt: skip
    assert main(argv) == 0
    data = json.loads((tmp_path / "results.json").read_text())
    cells = {(c["level"], c["policy"]): c for c in data["cells"]}
    assert set(cells) == {(lv, p) for lv in ("none", "high") for p in ("static-plan", "replanning")}
    assert cells[("none", "static-plan")]["makespans"] == cells[("none", "replanning")]["makespans"]
    assert data["bounds"][0]["values"][0] <= cells[("none", "replanning")]["makespans"][0]
    assert (tmp_path / "uncertainty.png").stat().st_size > 0
    assert "| e2s2 | 2 | high |" in (tmp_path / "table.md").read_text()
    assert main(["uncertainty", "--seeds", "0"]) == 1
