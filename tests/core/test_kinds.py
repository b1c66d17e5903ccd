"""The kind table (``multicrane.core.kinds``): every room reads a kind's rules from its entry.

Two halves. Over the built-in kinds, each entry's fields equal what the loader, the checks,
the site, the observations, the writer and the viewer do with that kind. Then two new kinds
are added in this file alone (a ``girder``: a horizontal bar resting on named columns, not
observed as a beam; an ``awning``: a horizontal panel resting on the girders under it,
observed as a beam), a small site of columns, a girder and an awning loads, is refused where
it breaks their entries, writes itself back, and is built by the planners in both decision
modes; the entries are removed afterwards. A new kind is one table entry plus its tests.
"""

from __future__ import annotations

import numpy as np
import pytest

import multicrane
import policies
from multicrane.core.codes import Kind, Status
from multicrane.core.kinds import (
    FRAME_COLORS,
    HORIZONTAL_BAR,
    HORIZONTAL_PANEL,
    KINDS,
    NAMED,
    SHAPES,
    STACKED,
    UNDER_SOME,
    VERTICAL_BAR,
    VERTICAL_PANEL,
    KindSpec,
    add_kind,
    ifc_kind,
    kind_named,
    kind_spec,
)
from multicrane.core.schema import ScenarioError
from multicrane.episodes.rollout import run_episode
from multicrane.render.scene import pack_colors
from multicrane.scenario.catalog import scenario_names
from multicrane.scenario.components_table import read_component
from multicrane.scenario.generator import generate
from multicrane.scenario.loader import load_scenario, parse_scenario
from multicrane.scenario.toml_table import TomlTable
from multicrane.scenario.writer import to_toml
from multicrane.sim import geometry
from multicrane.sim.site import Site

BUILT_IN = list(Kind)

# One target of each shape, on a 12 x 12 x 8 site.
SAMPLE_TARGETS = {
    VERTICAL_BAR: [[5, 5, 1], [5, 5, 3]],
    HORIZONTAL_BAR: [[5, 5, 3], [7, 5, 3]],
    HORIZONTAL_PANEL: [[5, 5, 3], [7, 6, 3]],
    VERTICAL_PANEL: [[5, 5, 1], [7, 5, 2]],
}


def read(data: dict):
    """One ``[[components]]`` table read as the loader reads it (pre-built: no initial)."""
    table = TomlTable("t.toml", "components[0]", {"id": "a", "prebuilt": True, **data})
    return read_component(table, ["a", "b"], (12, 12, 8), False, False)


def scenarios():
    """The shipped sites and generated ones of every family: every built-in kind occurs."""
    made = [generate(family, 1) for family in ("frame", "hall", "precast")]
    return [load_scenario(n) for n in scenario_names()] + made


# -- the built-in kinds --------------------------------------------------------------------


def test_the_kind_enum_names_the_built_in_entries():
    assert [KINDS[k].code for k in BUILT_IN] == BUILT_IN
    assert all(KINDS[k].code is k for k in BUILT_IN)  # loaded scenarios keep ``Kind`` members
    assert [kind_spec(k).name for k in BUILT_IN] == ["column", "beam", "slab", "wall"]
    assert [kind_spec(k).shape for k in BUILT_IN] == list(SHAPES)
    assert kind_named("Beam") is KINDS[Kind.BEAM] and kind_named("girder") is None


@pytest.mark.parametrize("kind", BUILT_IN, ids=lambda k: k.name)
@pytest.mark.parametrize("shape", SHAPES)
def test_a_target_is_read_only_in_its_kinds_shape(kind, shape):
    spec = kind_spec(kind)
    data = {"kind": spec.name, "target": SAMPLE_TARGETS[shape]}
    if shape == spec.shape:
        assert read(data).kind is kind
    else:
        with pytest.raises(ScenarioError, match=r"components\[0\]\.target"):
            read(data)


@pytest.mark.parametrize("kind", BUILT_IN, ids=lambda k: k.name)
def test_length_and_named_supports_follow_the_entry(kind):
    spec = kind_spec(kind)
    target = SAMPLE_TARGETS[spec.shape]
    cells = len(geometry.pose_cells(*target))
    if spec.panel:
        with pytest.raises(ScenarioError, match="a panel has no length"):
            read({"kind": spec.name, "target": target, "length": cells})
    else:
        assert read({"kind": spec.name, "target": target, "length": cells}).length == cells
    named = {"kind": spec.name, "target": target, "supports": ["b"]}
    if spec.supports == STACKED:
        with pytest.raises(ScenarioError, match="only beams, slabs and walls name supports"):
            read(named)
    else:
        assert read(named).supports == (1,)


@pytest.mark.parametrize("scenario", scenarios(), ids=lambda s: s.name)
def test_loaded_sites_follow_each_kinds_entry(scenario):
    """Supports of the kinds each rests on; the site's waiting, the observation's beam
    column, the writer's length key and the replay colours as each entry says."""
    site = Site(scenario)
    text = to_toml(scenario)
    env = multicrane.parallel_env(scenario)
    obs, _ = env.reset(seed=0)
    table = env.observation_layout.split(obs["crane_0"]["observation"])["components"]
    colours = pack_colors(np.full(len(site.kind), Status.ASSEMBLED), site.kind)
    for i, c in enumerate(scenario.components):
        spec = kind_spec(c.kind)
        assert {scenario.components[j].kind for j in site.target_supports[i]} <= set(
            spec.rests_on
        ), c.id
        on_ground = min(z for _, _, z in geometry.pose_cells(*c.target)) == 1
        named = spec.supports == NAMED or (spec.supports != STACKED and not on_ground)
        assert bool(c.supports) == named, c.id  # stacked: implied; "under" rules: derived
        assert site.waits[i] == spec.waits_for_target
        if c.initial is not None:
            assert table[i, 7] == spec.beam_feature, c.id
        r, g, b, a = spec.colors[Status.ASSEMBLED]
        assert colours[i] == (r << 24) | (g << 16) | (b << 8) | a
        entry = text[text.index(f"id = {c.id!r}".replace("'", '"')) :].split("\n\n")[0]
        assert ("length = " in entry) == (not spec.panel), c.id


@pytest.mark.parametrize("kind", BUILT_IN, ids=lambda k: k.name)
def test_the_pick_up_rule_keeps_the_targets_shape(kind):
    spec = kind_spec(kind)
    target = tuple(tuple(c) for c in SAMPLE_TARGETS[spec.shape])
    length = len(geometry.pose_cells(*target))
    lying = ((2, 2, 1), (2 + length - 1, 2, 1))
    if spec.panel:
        sides = sorted(n for n in geometry.extent(*target) if n > 1)
        lying = ((2, 2, 1), (2 + sides[0] - 1, 2 + sides[1] - 1, 1))
    lifted = geometry.lifted_pose(kind, length, lying, target, None)
    assert geometry.extent(*lifted) == geometry.extent(*target)
    if not spec.lifted_about_centre:
        assert lifted[0] == (2, 2, 2)  # stood upright on node 1, one cell up
    elif spec.upright:
        assert min(lifted[0][2], lifted[1][2]) == 2  # stood up one cell above the yard
    else:
        assert lifted[0][2] == target[0][2]  # raised to its target's height


def test_ifc_types_map_to_kinds_by_shape():
    assert ifc_kind("IfcMember", VERTICAL_BAR) is KINDS[Kind.COLUMN]
    assert ifc_kind("IfcMember", HORIZONTAL_BAR) is KINDS[Kind.BEAM]
    assert ifc_kind("IfcWall", HORIZONTAL_PANEL) is KINDS[Kind.SLAB]
    assert ifc_kind("IfcPlate", VERTICAL_PANEL) is KINDS[Kind.WALL]
    with pytest.raises(KeyError):
        ifc_kind("IfcColumn", HORIZONTAL_BAR)


@pytest.mark.parametrize(
    ("change", "words"),
    [
        ({"code": Kind.BEAM}, "code 1 is taken"),
        ({"name": "Beam"}, "is taken"),
        ({"name": "Strut"}, "lower case"),
        ({"shape": "sphere"}, "shape 'sphere'"),
        ({"supports": "glued"}, "supports 'glued'"),
        ({"supports": STACKED}, "only a vertical bar is stacked"),
        ({"rests_on": (99,)}, "codes of known kinds"),
        ({"rests_on": ()}, "at least one"),
        ({"colors": FRAME_COLORS[:3]}, "one RGBA per status"),
    ],
)
def test_a_bad_entry_is_refused(change, words):
    fields = {"code": 90, "name": "strut", "shape": HORIZONTAL_BAR, "supports": NAMED,
              "rests_on": (Kind.COLUMN,), "waits_for_target": True, "beam_feature": True,
              "colors": FRAME_COLORS}  # fmt: skip
    with pytest.raises(ValueError, match=words):
        add_kind(KindSpec(**{**fields, **change}))
    assert 90 not in KINDS


# -- a new kind, added here alone ----------------------------------------------------------

GREY = ((120, 120, 120, 255), (90, 90, 200, 255), (90, 200, 90, 255), (60, 60, 60, 255))
TEAL = ((0, 128, 128, 255), (0, 90, 255, 255), (0, 230, 120, 255), (0, 70, 70, 255))

SITE = """\
format = 1
name = "kinds"

[site]
size = [12, 8, 6]
construction_area = { min = [6, 0], max = [11, 7] }
foundations = [[7, 3], [10, 3]]

[rules]
cranes = 2
step_limit = 300
order = ["c1", "c2", "g", "k"]

[[components]]
id = "c1"
kind = "column"
length = 3
initial = [[0, 0, 1], [2, 0, 1]]
target = [[7, 3, 1], [7, 3, 3]]

[[components]]
id = "c2"
kind = "column"
length = 3
initial = [[0, 2, 1], [2, 2, 1]]
target = [[10, 3, 1], [10, 3, 3]]

[[components]]
id = "g"
kind = "girder"
length = 2
initial = [[0, 4, 1], [1, 4, 1]]
target = [[8, 3, 3], [9, 3, 3]]
supports = ["c1", "c2"]

[[components]]
id = "k"
kind = "awning"
initial = [[3, 5, 1], [4, 6, 1]]
target = [[8, 3, 4], [9, 4, 4]]
"""
C1, C2, G, K = range(4)


@pytest.fixture
def new_kinds():
    """The girder and the awning in the table for one test."""
    code = max(KINDS) + 1
    girder = add_kind(KindSpec(code, "girder", HORIZONTAL_BAR, NAMED, (Kind.COLUMN,),
                               waits_for_target=True, beam_feature=False, colors=GREY))  # fmt: skip
    awning = add_kind(KindSpec(code + 1, "awning", HORIZONTAL_PANEL, UNDER_SOME, (code,),
                               waits_for_target=True, beam_feature=True, colors=TEAL))  # fmt: skip
    yield girder, awning
    del KINDS[girder.code], KINDS[awning.code]


def test_a_new_kind_loads_and_writes_back_by_its_entry(new_kinds):
    girder, awning = new_kinds
    s = parse_scenario(SITE, source="kinds.toml")
    assert [c.kind for c in s.components] == [Kind.COLUMN, Kind.COLUMN, girder.code, awning.code]
    assert s.components[G].supports == (C1, C2) and s.components[K].supports == (G,)
    assert s.components[K].length == 4
    text = to_toml(s)
    assert 'kind = "girder"\nlength = 2' in text and 'kind = "awning"\ntarget' in text
    assert parse_scenario(text, source="kinds.toml").components == s.components
    site = Site(s)
    assert site.target_supports == [[], [], [C1, C2], [G]]
    assert site.waits == [False, False, True, True]
    lifted = geometry.pickup_pose(s.components[K], s.beam_lift_z)
    assert lifted == ((3, 5, 4), (4, 6, 4))  # raised flat to its target's height


@pytest.mark.parametrize(
    ("old", "new", "words"),
    [
        ('kind = "awning"', 'kind = "tent"',
         "'column', 'beam', 'slab', 'wall', 'girder' or 'awning'"),
        ('supports = ["c1", "c2"]', 'supports = ["c1", "k"]', "'k' is not a column"),
        ('supports = ["c1", "c2"]', "supports = []", "a girder target needs the column targets"),
        ("target = [[8, 3, 3], [9, 3, 3]]", "target = [[8, 3, 2], [8, 3, 3]]",
         "a girder target must lie horizontally"),
        ('kind = "awning"', 'kind = "awning"\nlength = 4', "a panel has no length"),
        ("target = [[8, 3, 4], [9, 4, 4]]", "target = [[8, 5, 4], [9, 6, 4]]",
         "awning 'k' has no support: no girder target directly under it"),
        ("target = [[8, 3, 4], [9, 4, 4]]", 'target = [[8, 3, 4], [9, 4, 4]]\nsupports = ["c1"]',
         "'c1' is not a girder target directly under awning 'k'"),
        ('length = 3\ninitial = [[0, 0, 1], [2, 0, 1]]', 'length = 3\ninitial = [[0, 0, 1], '
         '[2, 0, 1]]\nsupports = ["g"]', "only beams, slabs, walls, girders and awnings name"),
    ],
)  # fmt: skip
def test_a_new_kind_is_refused_where_it_breaks_its_entry(new_kinds, old, new, words):
    assert old in SITE
    with pytest.raises(ScenarioError) as err:
        parse_scenario(SITE.replace(old, new, 1), source="kinds.toml")
    assert words in str(err.value)


def test_a_new_kind_is_observed_drawn_and_built(new_kinds):
    girder, awning = new_kinds
    s = parse_scenario(SITE, source="kinds.toml")
    env = multicrane.parallel_env(s)
    obs, _ = env.reset(seed=0)
    table = env.observation_layout.split(obs["crane_0"]["observation"])["components"]
    assert table[:, 7].tolist() == [0.0, 0.0, 0.0, 1.0]  # the entries' beam_feature
    assert not obs["crane_0"]["action_mask"][8 + G]  # it waits for its columns
    colours = pack_colors(np.zeros(4, dtype=np.int8), env.sim.site.kind)
    assert colours[G] == (120 << 24) | (120 << 16) | (120 << 8) | 255
    assert colours[K] == (0 << 24) | (128 << 16) | (128 << 8) | 255
    assert run_episode(env, policies.make("prioritized", env, seed=0), seed=0)["success"]
    task = multicrane.parallel_env(s, decisions="task")
    obs, _ = task.reset(seed=0)
    components = task.observation_layout.split(obs["crane_0"]["observation"])["components"]
    assert components[:, 0].tolist() == [0.0, 0.0, 0.0, 1.0]
    assert run_episode(task, policies.make("greedy", task, seed=0), seed=0)["success"]
