"""Tests of the strict scenario loader (``multicrane.scenario.loader``).

One valid base scenario (the paper's e2s2 plus an obstacle box in the yard) is parsed and
checked value by value. Every broken case is that base with one small text edit; the loader
must reject it with a ScenarioError whose message names the file, the offending key and value,
and the problem. Loading by name and by path, and a seeded fuzz test (errors are always
ScenarioError, never KeyError/TypeError/IndexError), complete the module.
"""

from __future__ import annotations

import hashlib
import json
import random
import re
from pathlib import Path

import pytest

from multicrane.core.codes import Kind
from multicrane.core.schema import Box, RewardSpec, Scenario, ScenarioError
from multicrane.scenario import catalog
from multicrane.scenario.catalog import resolve
from multicrane.scenario.loader import load_scenario, parse_scenario

BASE = """\
format = 1
name = "base"
description = "e2s2 (paper Env2, Scenario 2) with an obstacle box in the yard."

[site]
size = [15, 15, 8]
construction_area = { min = [6, 8], max = [12, 14] }
foundations = [[9, 9], [9, 13]]
obstacles = [{ min = [0, 10, 1], max = [1, 12, 3] }]

[rules]
cranes = 2
step_limit = 100
interchangeable_targets = true
order = ["2", "3", "1"]

[reward]
completion = 10

[[components]]
id = "1"
kind = "beam"
length = 3
initial = [[4, 4, 1], [6, 4, 1]]
target = [[9, 10, 4], [9, 12, 4]]
supports = ["2", "3"]

[[components]]
id = "2"
kind = "column"
length = 4
initial = [[7, 3, 1], [4, 3, 1]]
target = [[9, 9, 1], [9, 9, 4]]

[[components]]
id = "3"
kind = "column"
length = 4
initial = [[7, 2, 1], [4, 2, 1]]
target = [[9, 13, 1], [9, 13, 4]]
"""


def edit(text: str, old: str | tuple[str, ...], new: str | tuple[str, ...]) -> str:
    """Replace each ``old`` substring (which must occur exactly once) by its ``new``."""
    olds = (old,) if isinstance(old, str) else old
    news = (new,) if isinstance(new, str) else new
    assert len(olds) == len(news)
    for o, n in zip(olds, news, strict=True):
        assert o != n, f"edit {o!r} changes nothing"
        assert text.count(o) == 1, f"{o!r} must occur exactly once in the base scenario"
        text = text.replace(o, n)
    return text


# ---------------------------------------------------------------------------------------------
# The valid base


def test_base_scenario_parses_with_the_expected_values():
    s = parse_scenario(BASE, source="base.toml")
    assert isinstance(s, Scenario)
    assert s.name == "base"
    assert s.description.startswith("e2s2")
    assert s.source == "base.toml"
    assert s.sha256 == hashlib.sha256(BASE.encode()).hexdigest()
    assert s.size == (15, 15, 8)
    assert s.construction_area == (6, 8, 12, 14)
    assert s.foundations == ((9, 9), (9, 13))
    assert s.obstacles == (Box((0, 10, 1), (1, 12, 3)),)
    assert len(s.obstacle_cells()) == 2 * 3 * 3
    assert s.n_components == 3
    assert s.ids == ("1", "2", "3")
    assert [c.kind for c in s.components] == [Kind.BEAM, Kind.COLUMN, Kind.COLUMN]
    assert [c.length for c in s.components] == [3, 4, 4]
    beam, col2, col3 = s.components
    assert beam.initial == ((4, 4, 1), (6, 4, 1))
    assert beam.target == ((9, 10, 4), (9, 12, 4))
    assert beam.supports == (1, 2)  # indices, not ids
    assert col2.initial == ((7, 3, 1), (4, 3, 1))
    assert col3.target == ((9, 13, 1), (9, 13, 4))
    assert col2.supports == () and col3.supports == ()
    assert not any(c.prebuilt for c in s.components)
    assert all(c.prebuilt_on == () for c in s.components)
    assert s.order == (1, 2, 0)  # ids "2", "3", "1" as indices
    assert s.cranes == 2
    assert s.step_limit == 100
    assert s.interchangeable_targets is True
    assert s.assembly_steps == 1
    assert s.beam_lift_z is None
    assert s.random_start is None
    # completion is written as an integer and read as a float; the rest are the paper's defaults
    assert s.reward == RewardSpec(
        completion=10.0, move_limit=15, over_limit_cost=2.0, step_cost=1.0
    )
    assert isinstance(s.reward.completion, float)


def test_base_scenario_defaults_when_optional_keys_are_left_out():
    text = edit(BASE, "[reward]\ncompletion = 10\n", "")
    text = edit(text, 'order = ["2", "3", "1"]\n', "")
    text = edit(text, "interchangeable_targets = true\n", "")
    text = edit(text, "cranes = 2\n", "")
    text = edit(text, 'name = "base"\n', "")
    s = parse_scenario(text, source="defaults.toml", default_name="fallback")
    assert s.name == "fallback"
    assert s.reward == RewardSpec()
    assert (s.reward.completion, s.reward.move_limit) == (10.0, 15)
    assert (s.reward.over_limit_cost, s.reward.step_cost) == (2.0, 1.0)
    assert s.order == (0, 1, 2)  # list order
    assert s.interchangeable_targets is False
    assert s.cranes == 1


def test_base_scenario_from_bytes_and_str_agree():
    a = parse_scenario(BASE, source="a.toml")
    b = parse_scenario(BASE.encode(), source="a.toml")
    assert a == b


def test_prebuilt_component_parses():
    prebuilt = 'prebuilt = true\nprebuilt_on = ["2", "3"]\n'
    text = edit(BASE, "initial = [[7, 2, 1], [4, 2, 1]]\n", prebuilt)
    s = parse_scenario(text, source="prebuilt.toml")
    col3 = s.components[2]
    assert col3.prebuilt is True
    assert col3.initial is None
    assert col3.prebuilt_on == (1, 2)


# ---------------------------------------------------------------------------------------------
# Broken scenarios: (case_id, old, new, fragments the message must contain besides the file).
# old/new are one substring of BASE and its replacement, or tuples of them for two-edit cases.

OBSTACLE = "obstacles = [{ min = [0, 10, 1], max = [1, 12, 3] }]"

# fmt: off
CASES: list[tuple[str, str | tuple[str, ...], str | tuple[str, ...], tuple[str, ...]]] = [
    # -- not TOML at all
    ("toml_syntax_missing_equals", "step_limit = 100", "step_limit 100",
     ("not valid TOML", "line 13")),
    ("toml_duplicate_key", "cranes = 2", "cranes = 2\ncranes = 3",
     ("not valid TOML", "line 13")),
    ("toml_unclosed_array", "size = [15, 15, 8]", "size = [15, 15, 8",
     ("not valid TOML", "Unclosed array", "line ")),
    # -- unknown keys (misspellings)
    ("unknown_top_level_key", "format = 1\n", 'format = 1\ncolour = "red"\n',
     ("colour", "'red'", "unknown key")),
    ("unknown_component_key_misspelt_target", "target = [[9, 9, 1], [9, 9, 4]]",
     "tagret = [[9, 9, 1], [9, 9, 4]]", ("components[1].tagret", "unknown key")),
    ("unknown_component_key_misspelt_supports", 'supports = ["2", "3"]',
     'suports = ["2", "3"]', ("components[0].suports", "['2', '3']", "unknown key")),
    ("unknown_site_key", "foundations = [[9, 9], [9, 13]]", "foundation = [[9, 9], [9, 13]]",
     ("site.foundation", "[[9, 9], [9, 13]]", "unknown key")),
    ("unknown_rules_key", "cranes = 2", "crane = 2", ("rules.crane", "2", "unknown key")),
    ("unknown_reward_key", "completion = 10", "completon = 10",
     ("reward.completon", "10", "unknown key")),
    ("unknown_obstacle_key", "max = [1, 12, 3] }", "max = [1, 12, 3], solid = true }",
     ("site.obstacles[0].solid", "True", "unknown key")),
    ("unknown_area_key", "max = [12, 14] }", "max = [12, 14], mid = [9, 11] }",
     ("site.construction_area.mid", "[9, 11]", "unknown key")),
    # -- missing required keys
    ("missing_format", "format = 1\n", "", ("format", "missing")),
    ("missing_rules_step_limit", "step_limit = 100\n", "", ("rules.step_limit", "missing")),
    ("missing_component_target", "target = [[9, 10, 4], [9, 12, 4]]\n", "",
     ("components[0].target", "missing")),
    ("missing_component_kind", 'kind = "beam"\n', "", ("components[0].kind", "missing")),
    ("missing_initial_without_random_start", "initial = [[7, 3, 1], [4, 3, 1]]\n", "",
     ("components[1].initial", "'2'", "required")),
    ("missing_site_table", "[site]\n", "[sight]\n", ("[site]", "missing")),
    # -- wrong types
    ("size_is_a_string", "size = [15, 15, 8]", 'size = "15"', ("site.size", "'15'", "list")),
    ("size_has_two_entries", "size = [15, 15, 8]", "size = [15, 15]",
     ("site.size", "[15, 15]", "3 integers")),
    ("step_limit_is_a_string", "step_limit = 100", 'step_limit = "100"',
     ("rules.step_limit", "'100'", "int")),
    ("step_limit_is_a_bool", "step_limit = 100", "step_limit = true",
     ("rules.step_limit", "True", "int")),
    ("interchangeable_is_a_string", "interchangeable_targets = true",
     'interchangeable_targets = "yes"', ("rules.interchangeable_targets", "'yes'", "bool")),
    ("initial_is_a_string", "initial = [[7, 3, 1], [4, 3, 1]]", 'initial = "7, 3, 1"',
     ("components[1].initial", "'7, 3, 1'", "list")),
    ("cell_is_a_string", "initial = [[7, 3, 1], [4, 3, 1]]", 'initial = ["7, 3, 1", [4, 3, 1]]',
     ("components[1].initial", "'7, 3, 1'", "integers")),
    ("cell_has_a_float", "target = [[9, 9, 1], [9, 9, 4]]", "target = [[9, 9, 1.5], [9, 9, 4]]",
     ("components[1].target", "1.5", "integers")),
    ("pose_has_three_cells", "target = [[9, 9, 1], [9, 9, 4]]",
     "target = [[9, 9, 1], [9, 9, 2], [9, 9, 4]]",
     ("components[1].target", "[9, 9, 2]", "two cells")),
    ("site_is_not_a_table", "[site]\n", 'site = "big"\n[sight]\n', ("site", "'big'", "table")),
    ("kind_truss", 'kind = "beam"', 'kind = "truss"', ("components[0].kind", "'truss'", "column")),
    ("slab_with_length", 'kind = "beam"', 'kind = "slab"',
     ("components[0].length", "3", "a panel has no length")),
    ("length_zero", "length = 3", "length = 0", ("components[0].length", "0", "at least 1")),
    # -- format and site
    ("unsupported_format", "format = 1", "format = 2", ("format", "2", "unsupported")),
    ("size_zero_entry", "size = [15, 15, 8]", "size = [15, 0, 8]",
     ("site.size", "[15, 0, 8]", "must be")),
    ("size_negative_height", "size = [15, 15, 8]", "size = [15, 15, -8]",
     ("site.size", "[15, 15, -8]", "must be")),
    ("area_outside_site", "max = [12, 14] }", "max = [12, 15] }",
     ("site.construction_area.max", "[12, 15]", "outside the site")),
    ("area_max_below_min", "max = [12, 14] }", "max = [5, 14] }",
     ("site.construction_area.max", "[5, 14]", "below min")),
    ("foundation_outside_site", "foundations = [[9, 9], [9, 13]]",
     "foundations = [[9, 9], [9, 15]]", ("site.foundations[1]", "[9, 15]", "outside the site")),
    ("duplicate_foundation", "foundations = [[9, 9], [9, 13]]",
     "foundations = [[9, 9], [9, 13], [9, 9]]", ("site.foundations[2]", "[9, 9]", "duplicate")),
    ("obstacle_outside_site", "max = [1, 12, 3]", "max = [1, 15, 3]",
     ("site.obstacles[0].max", "[1, 15, 3]", "outside the site")),
    ("obstacle_underground", "min = [0, 10, 1]", "min = [0, 10, 0]",
     ("site.obstacles[0].min", "[0, 10, 0]", "outside the site")),
    ("obstacle_max_below_min", "max = [1, 12, 3]", "max = [1, 9, 3]",
     ("site.obstacles[0].max", "[1, 9, 3]", "below min")),
    ("obstacles_overlap", OBSTACLE,
     "obstacles = [{ min = [0, 10, 1], max = [1, 12, 3] }, { min = [1, 12, 3], max = [2, 13, 3] }]",
     ("site.obstacles[1].min", "[1, 12, 3]", "overlaps obstacle [0]")),
    # -- pose geometry
    ("target_above_height", "target = [[9, 10, 4], [9, 12, 4]]",
     "target = [[9, 10, 9], [9, 12, 9]]",
     ("components[0].target", "[9, 10, 9]", "outside the site")),
    ("initial_x_negative", "initial = [[7, 3, 1], [4, 3, 1]]", "initial = [[2, 3, 1], [-1, 3, 1]]",
     ("components[1].initial", "[-1, 3, 1]", "outside the site")),
    ("diagonal_nodes", "target = [[9, 9, 1], [9, 9, 4]]", "target = [[9, 9, 1], [10, 10, 4]]",
     ("components[1].target", "[10, 10, 4]", "line")),
    ("length_inconsistent_with_cells", "length = 3", "length = 5",
     ("components[0].", "length is 5", "spans 3 cells")),
    ("column_target_horizontal", "target = [[9, 9, 1], [9, 9, 4]]",
     "target = [[9, 9, 1], [12, 9, 1]]", ("components[1].target", "[12, 9, 1]", "upright")),
    ("beam_target_vertical", "target = [[9, 10, 4], [9, 12, 4]]",
     "target = [[9, 11, 2], [9, 11, 4]]", ("components[0].target", "[9, 11, 2]", "horizontal")),
    # -- overlaps and obstacles
    ("initials_overlap", "initial = [[7, 2, 1], [4, 2, 1]]", "initial = [[7, 3, 1], [4, 3, 1]]",
     ("components[2].initial", "[7, 3, 1]", "overlaps", "'2'")),
    ("initial_inside_obstacle", "initial = [[4, 4, 1], [6, 4, 1]]",
     "initial = [[0, 11, 1], [2, 11, 1]]", ("components[0].initial", "[0, 11, 1]", "obstacle")),
    ("target_inside_obstacle", OBSTACLE, "obstacles = [{ min = [9, 9, 2], max = [9, 9, 2] }]",
     ("components[1].target", "[9, 9, 2]", "obstacle")),
    ("targets_overlap", "target = [[9, 13, 1], [9, 13, 4]]", "target = [[9, 9, 1], [9, 9, 4]]",
     ("components[2].target", "[9, 9, 1]", "overlaps", "'2'")),
    # -- foundations and supports
    ("column_without_foundation", "foundations = [[9, 9], [9, 13]]", "foundations = [[9, 9]]",
     ("components[2].target", "(9, 13)", "no foundation")),
    ("beam_supports_unknown_id", 'supports = ["2", "3"]', 'supports = ["2", "7"]',
     ("components[0].supports", "'7'", "not a component id")),
    ("beam_supports_a_beam", 'supports = ["2", "3"]', 'supports = ["1", "3"]',
     ("components[0].supports", "'1'", "not a column")),
    ("beam_support_does_not_touch", "target = [[9, 10, 4], [9, 12, 4]]",
     "target = [[9, 10, 5], [9, 12, 5]]", ("components[0].supports", "'2'", "does not touch")),
    ("beam_without_supports", 'supports = ["2", "3"]\n', "",
     ("components[0].supports", "beam", "needs")),
    ("beam_with_empty_supports", 'supports = ["2", "3"]', "supports = []",
     ("components[0].supports", "[]", "needs")),
    ("beam_support_named_twice", 'supports = ["2", "3"]', 'supports = ["2", "2"]',
     ("components[0].supports", "'2'", "twice")),
    ("column_names_supports", "target = [[9, 9, 1], [9, 9, 4]]",
     'target = [[9, 9, 1], [9, 9, 4]]\nsupports = ["3"]',
     ("components[1].supports", "['3']", "only beams")),
    # -- ids and order
    ("duplicate_component_id", 'id = "3"', 'id = "2"', ("components[2].id", "'2'", "duplicate")),
    ("empty_component_id", 'id = "3"', 'id = ""', ("components[2].id", "''", "empty")),
    ("order_unknown_id", 'order = ["2", "3", "1"]', 'order = ["2", "3", "9"]',
     ("rules.order", "'9'", "not a component id")),
    ("order_lists_id_twice", 'order = ["2", "3", "1"]', 'order = ["2", "3", "1", "3"]',
     ("rules.order", "'3'", "twice")),
    ("order_misses_id", 'order = ["2", "3", "1"]', 'order = ["2", "3"]',
     ("rules.order", "'1'", "does not list")),
    # -- yard, construction area, pick-up
    ("pickup_blocked_by_obstacle", OBSTACLE,
     "obstacles = [{ min = [0, 10, 1], max = [1, 12, 3] }, { min = [7, 2, 2], max = [7, 2, 5] }]",
     ("components[2].initial", "[7, 2, 1]", "pick-up", "obstacle")),
    ("pickup_leaves_site", "size = [15, 15, 8]", "size = [15, 15, 4]",
     ("components[1].initial", "[7, 3, 1]", "pick-up", "leaves the site")),
    ("initial_in_construction_area", "initial = [[4, 4, 1], [6, 4, 1]]",
     "initial = [[6, 8, 1], [8, 8, 1]]",
     ("components[0].initial", "[6, 8, 1]", "construction area")),
    ("target_outside_construction_area", "target = [[9, 13, 1], [9, 13, 4]]",
     "target = [[3, 13, 1], [3, 13, 4]]",
     ("components[2].target", "[3, 13, 1]", "construction area")),
    # -- rules and reward values
    ("cranes_zero", "cranes = 2", "cranes = 0", ("rules.cranes", "0", "at least 1")),
    ("step_limit_zero", "step_limit = 100", "step_limit = 0",
     ("rules.step_limit", "0", "at least 1")),
    ("assembly_steps_zero", "cranes = 2", "cranes = 2\nassembly_steps = 0",
     ("rules.assembly_steps", "0", "at least 1")),
    ("beam_lift_z_above_height", "cranes = 2", "cranes = 2\nbeam_lift_z = 9",
     ("rules.beam_lift_z", "9", "1..8")),
    ("negative_move_limit", "completion = 10", "completion = 10\nmove_limit = -1",
     ("reward.move_limit", "-1", "negative")),
    # -- pre-built components
    ("prebuilt_on_without_interchangeable",
     ("interchangeable_targets = true", "initial = [[7, 2, 1], [4, 2, 1]]\n"),
     ("interchangeable_targets = false", 'prebuilt = true\nprebuilt_on = ["2"]\n'),
     ("components[2].prebuilt_on", "'2'", "interchangeable_targets")),
    ("prebuilt_on_without_prebuilt", "initial = [[7, 2, 1], [4, 2, 1]]",
     'initial = [[7, 2, 1], [4, 2, 1]]\nprebuilt_on = ["2"]',
     ("components[2].prebuilt_on", "'2'", "pre-built")),
    ("prebuilt_with_initial", "initial = [[7, 2, 1], [4, 2, 1]]",
     "initial = [[7, 2, 1], [4, 2, 1]]\nprebuilt = true",
     ("components[2].initial", "[7, 2, 1]", "pre-built")),
    ("prebuilt_on_other_kind", "initial = [[7, 2, 1], [4, 2, 1]]\n",
     'prebuilt = true\nprebuilt_on = ["1"]\n',
     ("components[2].prebuilt_on", "'1'", "kind or length")),
    # -- random start
    ("random_start_without_bands", "[reward]", "[random_start]\nbands = []\n\n[reward]",
     ("random_start.bands", "[]", "at least one band")),
    ("random_start_bad_direction", "[reward]",
     '[random_start]\nbands = [{ x = [0, 3], y = [0, 5] }]\ndirections = ["+z"]\n\n[reward]',
     ("random_start.directions", "'+z'", "not one of")),
    ("random_start_direction_not_a_string", "[reward]",
     '[random_start]\nbands = [{ x = [0, 3], y = [0, 5] }]\ndirections = [[1, 0]]\n\n[reward]',
     ("random_start.directions", "[1, 0]", "not one of")),
]
# fmt: on


def test_cases_are_distinct_and_many():
    ids = [case[0] for case in CASES]
    assert len(ids) == len(set(ids))
    assert len(ids) >= 20
    texts = [edit(BASE, old, new) for _, old, new, _ in CASES]
    assert len(set(texts)) == len(texts)


@pytest.mark.parametrize(
    ("old", "new", "fragments"),
    [pytest.param(old, new, fragments, id=case_id) for case_id, old, new, fragments in CASES],
)
def test_broken_scenario_is_rejected_with_a_useful_message(old, new, fragments):
    text = edit(BASE, old, new)
    with pytest.raises(ScenarioError) as info:
        parse_scenario(text, source="broken.toml")
    message = str(info.value)
    assert message.startswith("broken.toml"), message
    for fragment in fragments:
        assert fragment in message, f"{fragment!r} is not in the message {message!r}"


def test_scenario_error_is_a_value_error():
    assert issubclass(ScenarioError, ValueError)


def test_text_with_unencodable_characters_is_a_scenario_error():
    # A str holding a lone surrogate (e.g. read with errors="surrogateescape") is not UTF-8.
    with pytest.raises(ScenarioError, match="broken.toml"):
        parse_scenario(BASE + "# \udcff\n", source="broken.toml")


# ---------------------------------------------------------------------------------------------
# load_scenario and resolve


def test_missing_path_names_the_path(tmp_path):
    path = tmp_path / "nowhere" / "missing.toml"
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert str(path) in str(info.value)
    assert "no such" in str(info.value)
    with pytest.raises(ScenarioError, match="missing.toml"):
        load_scenario(str(path))


def test_unknown_shipped_name_lists_the_known_names(tmp_path, monkeypatch):
    shipped = tmp_path / "shipped"
    shipped.mkdir()
    for name in ("alpha", "beta"):
        (shipped / f"{name}.toml").write_text(BASE.replace('name = "base"\n', ""))
    monkeypatch.setattr(catalog, "scenarios_dir", lambda: shipped)
    assert catalog.scenario_names() == ["alpha", "beta"]
    with pytest.raises(ScenarioError) as info:
        resolve("gamma")
    message = str(info.value)
    assert "'gamma'" in message and "alpha" in message and "beta" in message
    # a shipped name resolves, case-insensitively, and its name defaults to the file stem
    assert resolve("ALPHA") == shipped / "alpha.toml"
    assert load_scenario("Beta").name == "beta"


def test_unknown_name_lists_the_real_shipped_names():
    with pytest.raises(ScenarioError) as info:
        resolve("no-such-scenario-xyz")
    for name in catalog.scenario_names():
        assert name in str(info.value)


@pytest.mark.parametrize("name", catalog.scenario_names())
def test_every_shipped_scenario_loads(name):
    s = load_scenario(name)
    assert s.source.endswith(f"{name}.toml")
    assert s.n_components >= 1


def test_file_in_tmp_path_loads_and_its_errors_name_it(tmp_path):
    good = tmp_path / "good.toml"
    good.write_text(BASE)
    s = load_scenario(good)
    assert s.source == str(good)
    assert s.sha256 == hashlib.sha256(good.read_bytes()).hexdigest()
    assert load_scenario(str(good)) == s
    assert load_scenario(s) is s  # a Scenario passes through

    bad = tmp_path / "bad.toml"
    bad.write_text(edit(BASE, "cranes = 2", "cranes = 0"))
    with pytest.raises(ScenarioError) as info:
        load_scenario(bad)
    assert str(info.value).startswith(str(bad))
    assert "rules.cranes" in str(info.value)


def test_non_utf8_file_is_rejected_clearly(tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes(BASE.replace("Scenario 2", "Szenario \u00e4").encode("latin-1"))
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    message = str(info.value)
    assert str(path) in message
    assert "UTF-8" in message


def test_loading_runs_no_code(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    marker = tmp_path / "pwned"
    payload = f"__import__('os').system('touch {marker}')"
    text = edit(BASE, 'name = "base"', f"name = {json.dumps(payload)}")
    in_cwd = "__import__('os').system('touch X')"
    text = edit(text, BASE.splitlines()[2], f"description = {json.dumps(in_cwd)}")
    path = tmp_path / "payload.toml"
    path.write_text(text)
    s = load_scenario(path)
    assert s.name == payload  # kept as data
    assert s.description == in_cwd
    assert not marker.exists()
    assert not (tmp_path / "X").exists()


# ---------------------------------------------------------------------------------------------
# Fuzz: every mutation is either a valid scenario or a ScenarioError

# A second base with a [random_start] table (component "3" is drawn at reset), so that the
# fuzz also reaches the random-start checks.
RANDOM_START_BASE = edit(
    edit(
        BASE,
        "[reward]",
        "[random_start]\nz = 1\nbands = [{ x = [0, 3], y = [0, 5] }, { x = [4, 5], y = [0, 2] }]\n"
        'directions = ["+x", "-y"]\n\n[reward]',
    ),
    "initial = [[7, 2, 1], [4, 2, 1]]\n",
    "",
)

INT_LITERAL = re.compile(r"(?<![\w.\"])-?\d+(?![\w.\"])")
STR_LITERAL = re.compile(r'"[^"\n]*"')
INT_REPLACEMENTS = ("-1", "999", '"x"', "2.5", "0", "true", "[]")
STR_REPLACEMENTS = ('"x"', '""', "1", "[]", "[1]", "{}")


def mutate(text: str, rng: random.Random) -> tuple[str, str]:
    """One random single-token mutation of ``text`` and a description of it."""
    lines = text.splitlines(keepends=True)
    roll = rng.random()
    if roll < 0.2:
        i = rng.randrange(len(lines))
        return "".join(lines[:i] + lines[i + 1 :]), f"delete line {i + 1}: {lines[i]!r}"
    if roll < 0.35:
        pattern, replacements = STR_LITERAL, STR_REPLACEMENTS
    else:
        pattern, replacements = INT_LITERAL, INT_REPLACEMENTS
    m = rng.choice(list(pattern.finditer(text)))
    new = rng.choice(replacements)
    line = text.count("\n", 0, m.start()) + 1
    return text[: m.start()] + new + text[m.end() :], f"line {line}: {m.group()} -> {new}"


@pytest.mark.parametrize("base", [BASE, RANDOM_START_BASE], ids=["base", "random_start"])
def test_fuzz_errors_are_always_scenario_errors(base):
    assert isinstance(parse_scenario(base), Scenario)
    rng = random.Random(20240611)
    crashes: list[str] = []
    outcomes = {"valid": 0, "rejected": 0}
    for _ in range(200):
        text, what = mutate(base, rng)
        try:
            result = parse_scenario(text, source="fuzz.toml")
        except ScenarioError as exc:
            outcomes["rejected"] += 1
            assert str(exc).startswith("fuzz.toml"), (what, str(exc))
        except Exception as exc:  # anything else is the bug this test looks for
            crashes.append(f"{what}: {type(exc).__name__}: {exc}")
        else:
            outcomes["valid"] += 1
            assert isinstance(result, Scenario)
    assert not crashes, "\n".join(crashes)
    assert outcomes["rejected"] > 50  # the mutations do reach the checks


def test_paths_are_accepted_as_path_objects(tmp_path):
    path = Path(tmp_path) / "base.toml"
    path.write_text(BASE)
    assert load_scenario(path).size == (15, 15, 8)
