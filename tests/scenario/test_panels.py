"""Panels (slabs and walls): geometry, the loader's shape and support rules, the state machine,
collisions and precedence on hand-built sites, and every reader (observation, render, replay
boxes, records, scenario text) and planner on the shipped precast scenarios.

``MINI`` is the hand-built site: a 3 x 2 wall panel standing on a foundation strip and a
3 x 2 slab resting on the wall's top row, both lying flat in the yard. Broken variants are
``MINI`` with one text edit, as in ``tests/scenario/test_scenario_loader.py``.
"""

from __future__ import annotations

from collections import Counter

import numpy as np
import pytest
from conftest import readable_env
from hypothesis import given
from hypothesis import strategies as st
from pettingzoo.test import parallel_api_test

import multicrane
import policies
from multicrane.bounds.makespan import lower_bound
from multicrane.core.codes import ASSEMBLE, CLAIM_BASE, EventType, Kind, Move, Status
from multicrane.core.schema import ScenarioError
from multicrane.episodes.rollout import run_episode
from multicrane.render.scene import PANEL_STATE_COLORS, STATE_COLORS, pack_colors
from multicrane.render.text import render_ansi
from multicrane.replay.record import EpisodeRecord, record_episode, resimulate
from multicrane.replay.viewer_episode import EpisodeCollector
from multicrane.scenario import generator
from multicrane.scenario.loader import load_scenario, parse_scenario
from multicrane.scenario.writer import to_toml
from multicrane.sim import geometry, shortest_paths
from multicrane.sim.reach import uncarriable
from multicrane.sim.simulator import Simulator

PRECAST = ("precast-frame", "precast-house")

MINI = """\
format = 1
name = "mini"

[site]
size = [12, 8, 6]
construction_area = { min = [6, 0], max = [11, 7] }
foundations = [[7, 3], [8, 3], [9, 3]]
obstacles = [{ min = [1, 1, 3], max = [1, 1, 3] }]

[rules]
cranes = 2
step_limit = 200
order = ["w", "s"]

[[components]]
id = "w"
kind = "wall"
initial = [[0, 0, 1], [2, 1, 1]]
target = [[7, 3, 1], [9, 3, 2]]

[[components]]
id = "s"
kind = "slab"
initial = [[1, 4, 1], [2, 6, 1]]
target = [[7, 3, 3], [9, 4, 3]]
"""
W, S = 0, 1


def cells_of(sim, comp):
    return sorted(sim.site.cell(j) for j in sim.state.cells[comp])


def box(lo, hi):
    return sorted(geometry.pose_cells(lo, hi))


# -- geometry ------------------------------------------------------------------------------


def _old_pose_cells(a, b):
    """The straight-line rule before panels existed (node 1 to node 2)."""
    n = geometry.pose_length(a, b)
    step = tuple((q > p) - (q < p) for p, q in zip(a, b, strict=True))
    return [(a[0] + i * step[0], a[1] + i * step[1], a[2] + i * step[2]) for i in range(n)]


cell = st.tuples(st.integers(0, 20), st.integers(0, 20), st.integers(1, 10))


@given(cell, st.integers(0, 2), st.integers(-6, 6), st.sampled_from([Kind.COLUMN, Kind.BEAM]))
def test_straight_poses_keep_their_cells_order_and_shape_key(a, axis, d, kind):
    b = list(a)
    b[axis] += d
    b = tuple(b)
    assert geometry.pose_cells(a, b) == _old_pose_cells(a, b)
    old_key = (kind, geometry.pose_length(a, b), geometry.axis_of(a, b))
    c = tuple(v + 1 for v in a)
    other = (c, tuple(v + 1 for v in b))  # the same shape elsewhere
    assert geometry.shape_key(kind, (a, b)) == geometry.shape_key(kind, other)
    assert old_key == (kind, geometry.pose_length(*other), geometry.axis_of(*other))


@given(cell, cell)
def test_panel_cells_fill_the_box_corner_to_corner(a, b):
    cells = geometry.pose_cells(a, b)
    ex = geometry.extent(a, b)
    assert len(cells) == len(set(cells)) == ex[0] * ex[1] * ex[2]
    assert cells[0] == a and cells[-1] == b


@pytest.mark.parametrize(
    ("kind", "initial", "target", "lift", "lifted"),
    [
        # slab: raised flat to its target's height, turned about its centre
        (Kind.SLAB, ((0, 0, 1), (2, 1, 1)), ((7, 3, 3), (9, 4, 3)), None, ((0, 0, 3), (2, 1, 3))),
        (Kind.SLAB, ((1, 4, 1), (2, 6, 1)), ((7, 3, 3), (9, 4, 3)), None, ((0, 5, 3), (2, 6, 3))),
        (Kind.SLAB, ((1, 4, 1), (2, 6, 1)), ((7, 3, 3), (9, 4, 3)), 5, ((0, 5, 5), (2, 6, 5))),
        # wall: stood upright in its target's orientation on its centre line, one cell up
        (Kind.WALL, ((0, 0, 1), (2, 1, 1)), ((7, 3, 1), (9, 3, 2)), None, ((0, 0, 2), (2, 0, 3))),
        (Kind.WALL, ((0, 0, 1), (1, 2, 1)), ((7, 3, 1), (9, 3, 2)), None, ((-1, 1, 2), (1, 1, 3))),
        (Kind.WALL, ((4, 4, 1), (8, 6, 1)), ((9, 2, 1), (9, 6, 3)), 7, ((6, 3, 2), (6, 7, 4))),
    ],
)
def test_panel_pick_up_rule(kind, initial, target, lift, lifted):
    assert geometry.lifted_pose(kind, 0, initial, target, lift) == lifted
    assert geometry.extent(*lifted) == geometry.extent(*target)


# -- the loader ----------------------------------------------------------------------------


def test_mini_loads_with_derived_supports():
    s = parse_scenario(MINI, source="mini.toml")
    assert [c.kind for c in s.components] == [Kind.WALL, Kind.SLAB]
    assert [c.length for c in s.components] == [6, 6]
    assert s.components[W].supports == () and s.components[S].supports == (W,)
    sim = Simulator(s)
    assert sim.site.target_supports == [[], [W]]
    # Naming the same support explicitly loads the same scenario.
    named = parse_scenario(MINI.replace('target = [[7, 3, 3], [9, 4, 3]]',
                                        'target = [[7, 3, 3], [9, 4, 3]]\nsupports = ["w"]'))
    assert named.components == s.components
    assert parse_scenario(to_toml(s), source="again.toml").components == s.components


WALL_ON_SLAB = MINI.replace('order = ["w", "s"]', 'order = ["w", "s", "w2"]') + """
[[components]]
id = "w2"
kind = "wall"
initial = [[0, 2, 1], [2, 3, 1]]
target = [[7, 4, 4], [9, 4, 5]]
"""


def test_a_wall_stands_on_the_slab_under_it():
    s = parse_scenario(WALL_ON_SLAB.replace("size = [12, 8, 6]", "size = [12, 8, 7]"))
    assert s.components[2].supports == (S,)
    assert Simulator(s).site.target_supports == [[], [W], [S]]


BROKEN = [
    ('target = [[7, 3, 3], [9, 4, 3]]', 'target = [[7, 3, 3], [9, 4, 4]]',
     ["components[1].target", "a slab target must be horizontal"]),
    ('target = [[7, 3, 3], [9, 4, 3]]', 'target = [[7, 3, 3], [9, 3, 3]]',
     ["components[1].target", "a slab spans at least 2"]),
    ('target = [[7, 3, 1], [9, 3, 2]]', 'target = [[7, 3, 1], [9, 4, 2]]',
     ["components[0].target", "must be upright"]),
    ('target = [[7, 3, 1], [9, 3, 2]]', 'target = [[7, 3, 1], [7, 3, 2]]',
     ["components[0].target", "a thinner one is a column"]),
    ('kind = "wall"', 'kind = "wall"\nlength = 6',
     ["components[0].length", "a panel has no length"]),
    ('initial = [[0, 0, 1], [2, 1, 1]]', 'initial = [[0, 0, 1], [2, 0, 2]]',
     ["components[0].initial", "lies flat in the yard"]),
    ('initial = [[0, 0, 1], [2, 1, 1]]', 'initial = [[0, 0, 1], [3, 1, 1]]',
     ["components[0].initial", "spans 4 x 2 cells", "2 x 3"]),
    ('initial = [[0, 0, 1], [2, 1, 1]]\n', '', ["components[0].initial", "'w'", "no random start"]),
    ('foundations = [[7, 3], [8, 3], [9, 3]]', 'foundations = [[7, 3], [8, 3]]',
     ["components[0].target", "wall 'w' has no support", "foundation", "[9, 3, 0]"]),
    ('target = [[7, 3, 3], [9, 4, 3]]', 'target = [[7, 3, 4], [9, 4, 4]]',
     ["components[1].target", "slab 's' has no support", "beam or wall"]),
    ('target = [[7, 3, 1], [9, 3, 2]]', 'target = [[7, 3, 1], [9, 3, 2]]\nsupports = ["s"]',
     ["components[0].supports", "'s' is not a slab or beam target directly under wall 'w'"]),
    ('kind = "slab"', 'kind = "roof"',
     ["components[1].kind", "'column', 'beam', 'slab' or 'wall'"]),
    ('initial = [[1, 4, 1], [2, 6, 1]]', 'initial = [[1, 4, 1], [2, 6, 1]]\nprebuilt = true',
     ["components[1].initial", "pre-built"]),
]  # fmt: skip


@pytest.mark.parametrize(("old", "new", "fragments"), BROKEN)
def test_broken_panels_are_rejected_naming_file_key_and_problem(old, new, fragments):
    assert old in MINI
    with pytest.raises(ScenarioError) as err:
        parse_scenario(MINI.replace(old, new, 1), source="mini.toml")
    msg = str(err.value)
    for fragment in ["mini.toml", *fragments]:
        assert fragment in msg, (fragment, msg)


def test_a_floating_upper_wall_is_rejected():
    text = WALL_ON_SLAB.replace("size = [12, 8, 6]", "size = [12, 8, 7]")
    with pytest.raises(ScenarioError, match=r"wall 'w2' has no support: no slab or beam target"):
        parse_scenario(text.replace("[[7, 4, 4], [9, 4, 5]]", "[[7, 6, 4], [9, 6, 5]]"), "x")


def test_an_enclosed_panel_target_is_unsolvable():
    """The solvability search moves the whole rigid rectangle: a wall whose target lies in a
    slot between obstacle walls is reachable from above only while the slot's opening is as
    wide as the wall."""
    only_wall = MINI[: MINI.index('[[components]]\nid = "s"')].replace('["w", "s"]', '["w"]')
    slot = (
        'obstacles = [{ min = [6, 2, 1], max = [10, 2, 4] }, { min = [6, 4, 1], max = [10, 4, 4] },'
        " { min = [6, 3, 1], max = [6, 3, 4] }, { min = [10, 3, 1], max = [10, 3, 4] }"
    )
    boxes = 'obstacles = [{ min = [1, 1, 3], max = [1, 1, 3] }]'
    parse_scenario(only_wall.replace(boxes, slot + "]"), "open")
    narrowed = slot + ", { min = [7, 3, 4], max = [7, 3, 4] }]"  # opening 2 cells wide
    with pytest.raises(ScenarioError, match="components\\[0\\].target.*cannot be reached"):
        parse_scenario(only_wall.replace(boxes, narrowed), "narrow")


# -- the state machine, collisions and precedence on the hand-built site ---------------------


def mini(**options) -> Simulator:
    sim = Simulator(parse_scenario(MINI, source="mini.toml"), **options)
    sim.reset(np.random.default_rng(0))
    return sim


def events(out):
    return [(e.type, e.component) for e in out.events]


def test_masks_and_claims_follow_the_supports():
    sim = mini()
    masks = sim.action_masks()
    assert masks[:, CLAIM_BASE + W].all() and not masks[:, CLAIM_BASE + S].any()
    out = sim.step([CLAIM_BASE + S, 6])  # forced: the slab has no supported target yet
    assert events(out) == [(EventType.ILLEGAL, S)]
    assert sim.state.status[S] == Status.INITIAL
    out = sim.step([CLAIM_BASE + W, CLAIM_BASE + W])
    assert events(out) == [(EventType.CLAIMED, W), (EventType.LIFTED, W),
                           (EventType.CLAIM_CONFLICT, W)]  # fmt: skip
    assert cells_of(sim, W) == box((0, 0, 2), (2, 0, 3))  # stood upright, one cell up
    assert sim.state.status[W] == Status.IN_TRANSIT and sim.state.held == [W, -1]


@pytest.mark.parametrize(
    ("moves", "blocked"),
    [
        ([Move.Y_PLUS], Move.Y_PLUS),  # the obstacle at (1, 1, 3) meets the wall's top middle cell
        ([Move.DOWN, Move.DOWN], Move.DOWN),  # the ground under the bottom row
        ([Move.X_MINUS], Move.X_MINUS),  # the site's edge
    ],
)
def test_a_move_is_blocked_by_any_cell_of_the_panel(moves, blocked):
    sim = mini()
    sim.step([CLAIM_BASE + W, 6])
    for m in moves[:-1]:
        sim.step([m, 6])
    before = cells_of(sim, W)
    assert sim.action_masks()[0][blocked] == 0
    out = sim.step([blocked, 6])
    assert events(out) == [(EventType.BLOCKED, W)]
    assert cells_of(sim, W) == before


def test_a_panel_blocks_another_component_with_its_whole_footprint():
    """The carried wall is lowered onto the slab lying in the yard: its first cell would be
    free, two other cells would enter the slab, so the move is masked and blocked."""
    sim = mini()
    sim.step([CLAIM_BASE + W, 6])
    sim.step([Move.UP, 6])
    sim.step([Move.UP, 6])  # z 4..5, above the obstacle at (1, 1, 3)
    for _ in range(4):
        sim.step([Move.Y_PLUS, 6])
    sim.step([Move.DOWN, 6])
    sim.step([Move.DOWN, 6])
    assert cells_of(sim, W) == box((0, 4, 2), (2, 4, 3))
    assert sim.site.cell(sim.state.cells[W][0]) == (0, 4, 2)  # lowered, still free
    assert sim.action_masks()[0][Move.DOWN] == 0
    out = sim.step([Move.DOWN, 6])
    assert events(out) == [(EventType.BLOCKED, W)]
    assert cells_of(sim, W) == box((0, 4, 2), (2, 4, 3))
    assert {sim.site.cell(j) for j in sim.state.cells[S]} == set(box((1, 4, 1), (2, 6, 1)))


def test_a_panel_arrives_only_when_its_whole_footprint_covers_the_target():
    sim = mini()
    sim.step([CLAIM_BASE + W, 6])
    dist = shortest_paths.distance_field(sim, W, [W])
    target = box((7, 3, 1), (9, 3, 2))
    while sim.state.status[W] == Status.IN_TRANSIT:
        move = shortest_paths.next_move(sim, W, dist)
        assert move is not None
        out = sim.step([move, 6])
        arrived = [e for e in out.events if e.type == EventType.ARRIVED]
        assert bool(arrived) == (cells_of(sim, W) == target)
    assert sim.state.status[W] == Status.ARRIVED and sim.state.filled[W] == W
    assert not sim.action_masks()[1][CLAIM_BASE + S]  # arrived is not assembled
    out = sim.step([ASSEMBLE, 6])
    assert events(out) == [(EventType.ASSEMBLY_STARTED, W), (EventType.ASSEMBLED, W)]
    assert sim.action_masks()[1][CLAIM_BASE + S]  # its support stands: the slab may go
    out = sim.step([6, CLAIM_BASE + S])
    assert cells_of(sim, S) == box((0, 5, 3), (2, 6, 3))  # lifted flat, turned to the target


def test_automatic_mode_skips_a_slab_until_its_wall_is_built():
    text = MINI.replace('order = ["w", "s"]', 'order = ["s", "w"]')
    sim = Simulator(parse_scenario(text, source="mini.toml"), n_cranes=1, auto=True)
    sim.reset(np.random.default_rng(0))
    assert sim.state.held == [W]


# -- readers -------------------------------------------------------------------------------


def test_observation_table_gives_a_panel_its_corners():
    env = multicrane.parallel_env("precast-house")
    obs, _ = env.reset(seed=0)
    table = env.observation_layout.split(obs["crane_0"]["observation"])["components"]
    X, Y, H = env.scenario.size
    scale = np.array([X - 1, Y - 1, H], dtype=np.float32)
    for i, c in enumerate(env.scenario.components):
        assert table[i, 0] == 1 and table[i, 7] == 0, c.id  # initial; not a beam
        assert np.allclose(table[i, 8:11], np.array(c.initial[0]) / scale), c.id
        assert np.allclose(table[i, 11:14], np.array(c.initial[1]) / scale), c.id


def test_render_shows_every_panel_cell():
    sim = mini()
    layers = "\n".join(render_ansi(sim).splitlines()[2:])  # below the header and legend
    assert layers.count("i") == 12  # 6 + 6 cells lying in the yard
    assert layers.count("+") == 12 and layers.count("#") == 1 and layers.count("F") == 0
    sim.step([CLAIM_BASE + W, 6])
    layers = "\n".join(render_ansi(sim).splitlines()[2:])
    assert layers.count("T") == 6 and layers.count("i") == 6  # held by a crane: upper case


def test_replay_boxes_and_panel_colours():
    env = multicrane.parallel_env("precast-house")
    collector = EpisodeCollector()
    env.reset(seed=0)
    collector.on_reset(env)
    lo, hi = collector.boxes()
    sizes = (hi - lo)[0]
    for i, c in enumerate(env.scenario.components):
        assert sorted(sizes[i].tolist()) == sorted(geometry.extent(*c.initial)), c.id
    status = np.zeros(len(env.scenario.components), dtype=np.int8)
    packed = pack_colors(status, env.sim.site.kind)
    assert len(set(packed.tolist())) == 1  # every component of the house is a panel
    assert not np.array_equal(STATE_COLORS, PANEL_STATE_COLORS)
    frame = multicrane.parallel_env("precast-frame").sim.site.kind
    colours = pack_colors(np.zeros(len(frame), dtype=np.int8), frame)
    plain = pack_colors(np.zeros(len(frame), dtype=np.int8))
    is_panel = np.array(frame) == int(Kind.SLAB)
    assert (colours[~is_panel] == plain[~is_panel]).all()
    assert (colours[is_panel] != plain[is_panel]).all()


@pytest.mark.parametrize("name", PRECAST)
def test_scenario_text_round_trip(name):
    s = load_scenario(name)
    assert parse_scenario(to_toml(s), source=s.source).components == s.components


def test_record_and_resimulate_a_panel_episode(tmp_path):
    env = readable_env("precast-house", n_cranes=2)
    rec = record_episode(env, policies.make("prioritized", env, seed=0), seed=0)
    again = EpisodeRecord.load(rec.save(tmp_path / "house.json.gz"))
    replay, rewards, final = resimulate(again)
    assert final["step"] == rec.steps
    assert (replay.sim.state.status == Status.ASSEMBLED).all()
    assert sum(rewards) == pytest.approx(rec.metrics["return"])


# -- planners ------------------------------------------------------------------------------


@pytest.mark.parametrize("name", PRECAST)
@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_prioritized_and_greedy_finish_the_precast_buildings(name, n):
    """Motion-level planners (the task-level prioritized one: tests/envs/test_task_mode.py)."""
    for policy in ("prioritized", "greedy"):
        env = multicrane.parallel_env(name, n_cranes=n)
        m = run_episode(env, policies.make(policy, env, seed=0), seed=0)
        assert m["success"], (name, n, policy)


@pytest.mark.parametrize("name", PRECAST)
def test_task_level_greedy_finishes_and_the_bound_is_below(name):
    env = multicrane.parallel_env(name, n_cranes=2, decisions="task")
    m = run_episode(env, policies.make("greedy", env, seed=0), seed=0)
    assert m["success"]
    bound = lower_bound(name, 2, seed=0, time_limit=10)
    assert 0 < bound.value <= m["makespan"]


# -- the generator's precast family --------------------------------------------------------

PRECAST_CASES = [
    {"yard": "one", "storeys": 2, "bays_x": 2, "cranes": 2, "obstacles": 0},
    {"yard": "two", "interchangeable": True, "obstacles": 3, "span": 5, "storeys": 1},
    {"yard": "around", "reach": True, "cranes": 3, "storeys": 1, "bays_x": 2},
]


@pytest.mark.parametrize("params", PRECAST_CASES)
def test_generated_precast_frames_load_and_are_built(params):
    s = generator.generate("precast", 3, **params)
    p = generator.draw_params("precast", 3, **params)
    text = to_toml(s)
    assert to_toml(generator.generate("precast", 3, **params)) == text  # deterministic
    assert parse_scenario(text, source=s.source, default_name=s.name) == s
    nx, storeys = p["bays_x"], p["storeys"]
    kinds = Counter(c.kind for c in s.components)
    assert kinds == {Kind.COLUMN: 2 * (nx + 1) * storeys, Kind.BEAM: 2 * nx * storeys,
                     Kind.SLAB: nx * storeys}  # fmt: skip
    position = {c: k for k, c in enumerate(s.order)}
    for i, c in enumerate(s.components):
        if c.kind is Kind.SLAB:  # on the two beams under its edges, listed after them
            assert [s.components[j].kind for j in c.supports] == [Kind.BEAM, Kind.BEAM]
            assert all(position[j] < position[i] for j in c.supports)
    if p["reach"]:
        assert s.crane_specs and uncarriable(s) is None
    parallel_api_test(multicrane.parallel_env(s), num_cycles=3)
    env = multicrane.parallel_env(s)
    assert run_episode(env, policies.make("prioritized", env, seed=0), seed=0)["success"]


@pytest.mark.parametrize(
    ("params", "words"),
    [
        ({"random_start": True}, "panels need fixed starts"),
        ({"bays_y": 2}, "one bay deep"),
        ({"span": 2}, "span >= 3"),
    ],
)
def test_bad_precast_parameters_are_named(params, words):
    with pytest.raises(ValueError, match=words):
        generator.generate("precast", 0, **params)


def test_rrd_replay_draws_panels_as_boxes_in_their_own_colours(tmp_path):
    """The first 40 steps of a precast-frame episode as a rerun file: per step one box per
    component, sized as its cells, slabs in the panel colours, columns and beams as usual."""
    pytest.importorskip("rerun")
    from test_replay import _column, _read_rrd

    from multicrane.replay import viewer

    env = readable_env("precast-frame", n_cranes=4, max_steps=40)
    rec = record_episode(env, policies.make("prioritized", env, seed=0), seed=0)
    chunks = _read_rrd(viewer.record_to_rrd(rec, tmp_path / "frame.rrd"))
    kinds = np.array(env.sim.site.kind)
    steps, colours = _column(chunks[("/components", False)], "Boxes3D:colors")
    _, halves = _column(chunks[("/components", False)], "Boxes3D:half_sizes")
    assert steps == list(range(41))
    assert colours[0] == pack_colors(np.zeros(len(kinds), dtype=np.int8), kinds).tolist()
    assert colours[-1] == pack_colors(env.sim.state.status, kinds).tolist()
    assert (env.sim.state.status[kinds == int(Kind.SLAB)] == Status.INITIAL).all()
    for i, c in enumerate(env.scenario.components):  # step 0: each lies flat in the yard
        assert sorted(2 * np.array(halves[0][i])) == sorted(geometry.extent(*c.initial)), c.id
