"""Per-crane timelines (``multicrane.replay.timeline``) and their lanes in the rerun replays.

Each episode's intervals are checked against the simulator's state at every step (what each
crane holds, the components' statuses, ``sim.crane_up``), seen by a listener beside the
timeline; a small micro-site episode is checked interval by interval against its events.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_rules import micro_site

import multicrane
import policies
from multicrane.core.codes import ASSEMBLE, WAIT, Status
from multicrane.replay.record import record_episode, resimulate_steps
from multicrane.replay.timeline import (
    CODES,
    Interval,
    Timeline,
    activity_codes,
    describe,
    timeline_of,
)
from multicrane.sim.site import NOBODY

INITIAL, IN_TRANSIT, ARRIVED, ASSEMBLED = (int(s) for s in Status)


class _States:
    """A listener keeping, per time, what each crane holds, the statuses and ``crane_up``."""

    def on_reset(self, env) -> None:
        self.held, self.status, self.up = [], [], []
        self.on_step(env, [], 0.0, [])

    def on_step(self, env, actions, reward, events) -> None:
        sim = env.sim
        self.held.append(list(sim.state.held))
        self.status.append(sim.state.status.copy())
        self.up.append([sim.crane_up(k) for k in range(sim.n_cranes)])


def _check(intervals: list[Interval], states: _States, assembly_steps: int) -> None:
    """Every step of every crane covered once; each interval agrees with the states."""
    T, n = len(states.held) - 1, len(states.up[0])
    assembling: dict[int, int] = {}
    for k in range(n):
        mine = [iv for iv in intervals if iv.crane == k]
        assert [iv.start for iv in mine] == [0] + [iv.end for iv in mine[:-1]]
        assert mine[-1].end == T and all(iv.steps > 0 for iv in mine)
        for i, iv in enumerate(mine):
            c = iv.component
            for s in range(iv.start, iv.end):  # the step from time s to s + 1
                assert states.up[s][k] == (iv.what != "down"), (iv, s)
                before, after = states.held[s][k], states.held[s + 1][k]
                if iv.what == "wait":  # (the automatic mode may assign one as the step ends)
                    assert before == NOBODY, (iv, s)
                    assert after == NOBODY or states.status[s + 1][after] == INITIAL
                elif iv.what == "lift":  # claimed in this step, or held before it
                    assert before == c or (before == NOBODY and after == c), (iv, s)
                    assert states.status[s][c] in (INITIAL, IN_TRANSIT), (iv, s)
                elif iv.what == "hold":
                    assert before == after == c and states.status[s + 1][c] == ARRIVED
                elif iv.what == "assemble":
                    assert before == c and states.status[s][c] == ARRIVED, (iv, s)
                else:
                    assert before == after == c
            interrupted = i + 1 < len(mine) and mine[i + 1].what == "down"
            if iv.what == "lift" and iv.end < T and not interrupted:  # ends where c arrives
                assert states.status[iv.end - 1][c] < ARRIVED <= states.status[iv.end][c], iv
            if iv.what == "assemble":
                assembling[c] = assembling.get(c, 0) + iv.steps
                if interrupted:  # a breakdown pauses it
                    assert states.status[iv.end][c] == ARRIVED, iv
                elif iv.end < T:
                    assert states.status[iv.end][c] == ASSEMBLED, iv
    done = [c for c, s in assembling.items() if states.status[-1][c] == ASSEMBLED]
    assert all(assembling[c] == assembly_steps for c in done), assembling


def _micro(tmp_path: Path, **kwargs) -> str:
    path = tmp_path / "micro.toml"
    path.write_text(micro_site(cranes=2, assembly_steps=3, **kwargs))
    return str(path)


def _episode(scenario: str, policy: str, seed: int = 1, wrap=None, **options):
    """Run an episode with a live timeline; re-simulate it with a second one and the states.
    Returns (live intervals, re-simulated intervals, states, record)."""
    env = multicrane.parallel_env(scenario, **options)
    live = Timeline()
    act = policies.factory(policy, paper=False)(env, seed)
    record = record_episode(env, wrap(act) if wrap else act, seed, policy, listeners=[live])
    again, states = Timeline(), _States()
    for _ in resimulate_steps(record, listeners=[again, states]):
        pass
    return live.intervals, again.intervals, states, record


# The micro site, 2 cranes, assembly_steps = 3, prioritized, seed 1; its events: claims of c1
# (crane 0) and c2 (crane 1) at step 1, c1 arrives at step 7, its assembly starts at 8 and ends
# at 10, when c2 arrives; c2's assembly runs 11..13; crane 0 claims b1 at 14, it arrives at
# 20 and is assembled 21..23. Steps t are the intervals' times t - 1 .. t.
MICRO_PRIORITIZED = [
    Interval(0, 0, 7, "lift", 0),
    Interval(0, 7, 10, "assemble", 0),
    Interval(0, 10, 13, "wait"),
    Interval(0, 13, 20, "lift", 2),
    Interval(0, 20, 23, "assemble", 2),
    Interval(1, 0, 10, "lift", 1),
    Interval(1, 10, 13, "assemble", 1),
    Interval(1, 13, 23, "wait"),
]


@pytest.mark.parametrize("decisions", ["motion", "task"])
def test_micro_episode_by_hand(tmp_path, decisions):
    live, again, states, record = _episode(_micro(tmp_path), "prioritized", decisions=decisions)
    assert live == again == MICRO_PRIORITIZED
    _check(live, states, assembly_steps=3)
    assert [describe(iv, ("c1", "c2", "b1")) for iv in live[:3]] == [
        "lifts c1", "assembles c1", "waits"
    ]  # fmt: skip


class _Hesitant:
    """A policy that waits twice before each assembly: the crane holds an arrived part."""

    def __init__(self, policy) -> None:
        self.policy, self.waited = policy, {}

    def __call__(self, observations):
        actions = dict(self.policy(observations))
        for agent, a in actions.items():
            if a == ASSEMBLE and self.waited.get(agent, 0) < 2:
                actions[agent] = WAIT
                self.waited[agent] = self.waited.get(agent, 0) + 1
            elif a == ASSEMBLE:
                self.waited[agent] = 0
        return actions


def test_holding_an_arrived_component(tmp_path):
    live, again, states, _ = _episode(_micro(tmp_path), "greedy", wrap=_Hesitant)
    assert live == again
    _check(live, states, assembly_steps=3)
    holds = [iv for iv in live if iv.what == "hold"]
    assert len(holds) == 3 and all(iv.steps == 2 for iv in holds)
    ids = ("c1", "c2", "b1")
    assert describe(holds[0], ids) == f"holds {ids[holds[0].component]}"


@pytest.mark.parametrize(
    "scenario, cranes, policy, options",
    [
        ("e2s2", 1, "greedy", {}),
        ("e2s2", 1, "greedy", {"auto": True}),
        ("hall-4c", 4, "prioritized", {"events": "high"}),
        ("hall-4c", 4, "prioritized", {"events": "high", "decisions": "task"}),
        ("frame2-3c", 3, "random", {"max_steps": 120, "events": "high"}),
    ],
)
def test_intervals_agree_with_the_states(scenario, cranes, policy, options):
    live, again, states, record = _episode(scenario, policy, seed=0, n_cranes=cranes, **options)
    assert live == again  # live (also task mode, several steps a decision) == re-simulated
    _check(live, states, multicrane.load_scenario(scenario).assembly_steps)
    assert live == timeline_of(record)
    if options.get("events"):  # breakdowns: exactly the times crane_up is false
        down = sum(iv.steps for iv in live if iv.what == "down")
        assert down == sum(not up for row in states.up[:-1] for up in row) > 0
    if not options.get("auto"):  # every component assembled in the episode had its interval
        built = np.flatnonzero((states.status[-1] == ASSEMBLED) & (states.status[0] != ASSEMBLED))
        assert sorted({iv.component for iv in live if iv.what == "assemble"}) == built.tolist()


def test_activity_codes():
    intervals = [Interval(0, 0, 2, "lift", 1), Interval(0, 2, 3, "down", 1),
                 Interval(1, 0, 3, "wait")]  # fmt: skip
    codes = activity_codes(intervals, 2, 3)
    assert codes.tolist() == [[CODES["lift"]] * 2 + [CODES["down"]], [CODES["wait"]] * 3]
    assert describe(intervals[1], ("a", "b")) == "breaks down holding b"


# -- the rerun replay -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def rr():
    rerun = pytest.importorskip("rerun")
    rerun.set_strict_mode(True)
    return rerun


def _timeline_entities(path: Path) -> dict[str, tuple[list[int], list]]:
    """(steps, values) of every ``cranes/crane_k/...`` timeline entity of an .rrd file."""
    from rerun.chunk import RrdReader

    found: dict[str, list] = {}
    for chunk in RrdReader(path).stream().to_chunks():
        if "/crane_" in chunk.entity_path and not chunk.is_static:
            batch = chunk.to_record_batch()
            column = "Scalars:scalars" if "activity" in chunk.entity_path else "TextLog:text"
            rows = found.setdefault(chunk.entity_path, [])
            steps, values = batch.column("step").to_pylist(), batch.column(column).to_pylist()
            rows += zip(steps, values, strict=True)
    out = {}
    for entity, rows in found.items():
        rows.sort(key=lambda r: r[0])
        out[entity] = ([s for s, _ in rows], [v[0] for _, v in rows])
    return out


def _lanes_in_blueprint(path: Path) -> list[str]:
    from rerun.chunk import RrdReader

    reader = RrdReader(path)
    origins = []
    for chunk in reader.stream(store=reader.blueprints()[0]).to_chunks():
        batch = chunk.to_record_batch()
        if "ViewBlueprint:space_origin" in batch.schema.names:
            origins += [o[0] for o in batch.column("ViewBlueprint:space_origin").to_pylist()]
    return sorted(o for o in origins if o.startswith("cranes"))


def test_rrd_has_the_timeline(rr, tmp_path):
    from multicrane.replay import viewer

    _, intervals, _, record = _episode(
        "hall-4c", "prioritized", seed=0, n_cranes=4, events="high", decisions="task"
    )
    path = viewer.record_to_rrd(record, tmp_path / "hall.rrd")
    found = _timeline_entities(path)
    codes = activity_codes(intervals, 4, record.steps)
    ids = multicrane.load_scenario("hall-4c").ids
    for k in range(4):
        steps, values = found[f"/cranes/crane_{k}/activity"]
        assert steps == list(range(record.steps)) and values == codes[k].tolist()
        mine = [iv for iv in intervals if iv.crane == k]
        assert found[f"/cranes/crane_{k}/log"] == (
            [iv.start for iv in mine], [describe(iv, ids) for iv in mine]
        )
    assert any("breaks down" in t for k in range(4) for t in found[f"/cranes/crane_{k}/log"][1])
    lanes = [f"cranes/crane_{k}/activity" for k in range(4)]
    assert _lanes_in_blueprint(path) == ["cranes", *lanes]

    # The live viewer logs the same timeline step by step.
    stream = viewer.new_recording("live")
    stream.save(tmp_path / "live.rrd")
    env = multicrane.parallel_env("hall-4c", n_cranes=4, events="high", decisions="task")
    viewer.run_live(env, policies.factory("prioritized", paper=False)(env, 0), 0, stream)
    stream.flush()
    stream.disconnect()
    assert _timeline_entities(tmp_path / "live.rrd") == found


def test_cli_record_writes_the_timeline(rr, tmp_path):
    from multicrane.cli import main

    rrd = tmp_path / "a.rrd"
    argv = ["replay", "record", "--scenario", "e3s2", "--cranes", "2", "--policy", "greedy"]
    assert main([*argv, "--seed", "1", "--rrd", str(rrd)]) == 0
    found = _timeline_entities(rrd)
    assert sorted(found) == [f"/cranes/crane_{k}/{leaf}" for k in (0, 1) for leaf in
                             ("activity", "log")]  # fmt: skip
    assert any(t.startswith("assembles") for t in found["/cranes/crane_0/log"][1])
