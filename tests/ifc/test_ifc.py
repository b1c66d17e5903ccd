"""IFC import (``multicrane.ifc.importer``): models built with ifcopenshell.api, imported, loaded,
checked against their geometry and solved by the prioritized planner; the skip report; wrong
files. Needs the ``ifc`` extra (skipped without ifcopenshell)."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

pytest.importorskip("ifcopenshell")

import multicrane  # noqa: E402
from multicrane.cli import main  # noqa: E402
from multicrane.episodes.rollout import run_episode  # noqa: E402
from multicrane.ifc.build import FrameModel, frame  # noqa: E402
from multicrane.ifc.importer import import_ifc  # noqa: E402
from multicrane.ifc.read import IfcImportError, classify  # noqa: E402
from multicrane.scenario.loader import load_scenario  # noqa: E402
from multicrane.sim import geometry  # noqa: E402
from policies.prioritized import PrioritizedPlanner  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


def _box(lo, hi) -> np.ndarray:
    return np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                     for z in (lo[2], hi[2])], float)  # fmt: skip


def _arc() -> np.ndarray:  # a beam curved in plan: x 0..6, bowing 1.5 m along y
    t = np.linspace(0, 1, 9)
    pts = [(6 * u, 1.5 * math.sin(math.pi * u) + dy, z) for u in t for dy in (0, 0.3)
           for z in (2.7, 3.0)]  # fmt: skip
    return np.array(pts, float)


@pytest.mark.parametrize(
    ("verts", "axis", "reason"),
    [
        (_box((0, 0, 0), (0.3, 0.3, 3)), 2, None),  # a column
        (_box((0, 0, 2.7), (6, 0.3, 3)), 0, None),  # a beam along x
        (_box((0, 0, 2.7), (0.3, 6, 3)), 1, None),  # a beam along y
        (_box((0, 0, 2.7), (6, 0.3, 3)) + [[0.1, 0, 0]] * 8, 0, None),  # moved: still straight
        (np.array([[0, 0, 0], [0.2, 0, 0], [4, 0, 3], [4.2, 0, 3.2]], float), None, "slanted"),
        (_arc(), None, "curved"),
    ],
)
def test_classify_axis_slant_and_curve(verts, axis, reason):
    got_axis, got_reason = classify(verts, 1.0)
    assert got_axis == axis
    assert (got_reason or "").startswith(reason or "")
    assert (got_reason is None) == (reason is None)


def _portal(path: Path) -> Path:
    return frame(1, 0, 1, name="portal").write(path)


def _two_storey(path: Path) -> Path:
    return frame(2, 3, 2, name="frame").write(path)


def _braced(path: Path) -> Path:
    """A portal frame with a slanted brace, and a beam too short between two close columns."""
    f = frame(1, 0, 1, name="braced")
    st = f.model.by_type("IfcBuildingStorey")[0]
    brace = f.linear(st, (0.2, 0, 0.3), (3.8, 0, 2.6), 0.15, 0.15, name="brace",
                     ifc_class="IfcMember")  # fmt: skip
    f.column(st, 8, 0, 0, 3, name="C-a")
    f.column(st, 9, 0, 0, 3, name="C-b")
    stub = f.linear(st, (8, 0, 2.85), (9, 0, 2.85), name="stub")
    f.write(path)
    return path, brace.GlobalId, stub.GlobalId


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    d = tmp_path_factory.mktemp("ifc")
    braced, brace_id, stub_id = _braced(d / "braced.ifc")
    return {"portal": _portal(d / "portal.ifc"), "frame": _two_storey(d / "frame.ifc"),
            "braced": braced, "brace_id": brace_id, "stub_id": stub_id}  # fmt: skip


@pytest.mark.parametrize(
    ("model", "cranes", "columns", "beams"),
    [("portal", 1, 2, 1), ("frame", 3, 24, 34), ("braced", 2, 4, 1)],
)
def test_models_import_load_and_are_solved(models, model, cranes, columns, beams):
    result = import_ifc(models[model], cranes=cranes)
    s = result.scenario
    kinds = [c.kind.name for c in s.components]
    assert (kinds.count("COLUMN"), kinds.count("BEAM")) == (columns, beams)
    env = multicrane.parallel_env(s)
    metrics = run_episode(env, PrioritizedPlanner(env), seed=0)
    assert metrics["success"], metrics


@pytest.mark.parametrize("cell", [1.0, 0.5])
@pytest.mark.parametrize("model", ["portal", "frame", "braced"])
def test_round_trip_every_cell_inside_its_element(models, model, cell):
    """Every component placed at its target lies inside its IFC element's box, grown by one
    cell; the file loads with the strict loader into the same scenario."""
    result = import_ifc(models[model], cell=cell)
    s = result.scenario
    by_id = {cid: result.building.parts[i].element for i, cid in result.ids.items()}
    for c in s.components:
        e = by_id[c.id]
        for cell_ in geometry.pose_cells(*c.target):
            lo, hi = result.grid.cell_box(cell_)
            for a in range(3):
                assert e.lo[a] - cell - 1e-9 <= lo[a] and hi[a] <= e.hi[a] + cell + 1e-9, (
                    c.id, cell_, e)
    path = Path(models[model]).with_suffix(f".{cell}.toml")
    path.write_text(result.text)
    loaded = load_scenario(path)
    assert loaded.components == s.components and loaded.foundations == s.foundations


def test_columns_on_foundations_and_beams_on_the_columns_they_touch(models):
    s = import_ifc(models["frame"]).scenario
    cells = {i: set(geometry.pose_cells(*c.target)) for i, c in enumerate(s.components)}
    for i, c in enumerate(s.components):
        x, y, z = c.target[0]
        if c.kind.name == "COLUMN" and z == 1:
            assert (x, y) in s.foundations
        if c.kind.name == "BEAM":
            assert len(c.supports) == 2
            assert all(geometry.touches(list(cells[i]), list(cells[j])) for j in c.supports)
    assert {c.id[:2] for c in s.components} == {"c1", "c2", "b1", "b2"}  # storeys kept
    assert "1 = 'Level 1'" in s.description and "2 = 'Level 2'" in s.description
    order = [s.components[i].target[0][2] for i in s.order]
    assert order == sorted(order)  # by height: buildable


def test_skip_report_names_every_skipped_element(models):
    result = import_ifc(models["braced"])
    lines = {k.global_id: k for k in result.skipped}
    assert set(lines) == {models["brace_id"], models["stub_id"]}
    brace, stub = lines[models["brace_id"]], lines[models["stub_id"]]
    assert (brace.ifc_type, brace.name) == ("IfcMember", "brace")
    assert brace.reason.startswith("slanted member")
    assert (stub.ifc_type, stub.name) == ("IfcBeam", "stub")
    assert stub.reason.startswith("too short for the cell size")
    for k in result.skipped:  # and in the file, as comments
        assert f"# {k.line()}" in result.text


def test_same_model_same_bytes(models):
    assert import_ifc(models["frame"]).text == import_ifc(models["frame"]).text


def test_continuous_beam_is_split_at_columns(tmp_path):
    f = FrameModel("continuous")
    st = f.storey("Level 1", 0.0)
    for x in (0, 4, 8):
        f.column(st, x, 0, 0, 3)
    beam = f.linear(st, (0, 0, 2.85), (8, 0, 2.85), name="long")
    s = import_ifc(f.write(tmp_path / "c.ifc")).scenario
    beams = [c for c in s.components if c.kind.name == "BEAM"]
    assert [c.length for c in beams] == [3, 3]
    assert "part 1 of 2" in import_ifc(tmp_path / "c.ifc").text and beam.GlobalId


def _panel_model(path: Path) -> Path:
    """A one-bay portal frame along x with a slab over the beams and a wall under a beam."""
    f = frame(1, 1, 1, name="panels")
    st = f.model.by_type("IfcBuildingStorey")[0]
    f.box(st, (0.15, -0.15, 3.0), (3.85, 4.15, 3.2), name="floor")
    f.box(st, (0.15, 3.9, 0.0), (3.85, 4.1, 2.4), name="infill", ifc_class="IfcWall")
    return f.write(path)


def test_panels_as_components_text(tmp_path):
    result = import_ifc(_panel_model(tmp_path / "p.ifc"), panels="components", load=False)
    data = tomllib.loads(result.text)
    panels = {c["kind"]: c for c in data["components"] if c["kind"] in ("slab", "wall")}
    assert set(panels) == {"slab", "wall"} and not result.skipped
    slab, wall = panels["slab"], panels["wall"]
    for p in (slab, wall):
        assert "length" not in p and len(p["target"]) == 2 and len(p["initial"]) == 2
        assert p["initial"][0][2] == p["initial"][1][2] == 1  # lying flat in the yard
        assert p["id"] in data["rules"]["order"]
    (a, b) = slab["target"]
    assert a[2] == b[2] == 4 and abs(a[0] - b[0]) == 2 and abs(a[1] - b[1]) == 4
    assert len(slab["supports"]) == 2 and all(i.startswith("b1-") for i in slab["supports"])
    (a, b) = wall["target"]
    assert a[1] == b[1] and (a[2], b[2]) == (1, 2)  # a wall across y, two cells high


def test_panels_as_components_load(tmp_path):
    assert import_ifc(_panel_model(tmp_path / "p.ifc"), panels="components").scenario


def test_panels_as_obstacles_or_skipped(tmp_path):
    path = _panel_model(tmp_path / "p.ifc")
    obst = import_ifc(path, panels="obstacles")
    assert obst.scenario.obstacles and not obst.skipped
    target_cells = {c for x in obst.scenario.components for c in geometry.pose_cells(*x.target)}
    assert not target_cells & obst.scenario.obstacle_cells()
    skipped = import_ifc(path, panels="skip")
    assert not skipped.scenario.obstacles
    assert sorted(k.ifc_type for k in skipped.skipped) == ["IfcSlab", "IfcWall"]


def test_cli_writes_the_file_and_the_report(models, tmp_path, capsys):
    out = tmp_path / "site.toml"
    assert main(["import-ifc", str(models["braced"]), "-o", str(out), "--cranes", "2"]) == 0
    text = capsys.readouterr().out
    assert "4 columns, 1 beams" in text and f"skipped IfcMember {models['brace_id']}" in text
    assert load_scenario(out).cranes == 2


def _ifc2x3_without_columns(path: Path) -> Path:
    f = FrameModel("no-columns", schema="IFC2X3")
    st = f.storey("Level 1", 0.0)
    f.linear(st, (0, 0, 2.85), (4, 0, 2.85))
    return f.write(path)


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda p: p.write_text("hello, not a model\n") and p, "not an IFC file"),
        (lambda p: p.write_bytes(b"") is not None and p, "the file is empty"),
        (lambda p: p, "no such file"),
        (_ifc2x3_without_columns, "IFC2X3 model with no IfcColumn"),
    ],
    ids=["not-ifc", "empty", "missing", "ifc2x3-no-columns"],
)
def test_wrong_files_get_one_clear_line(tmp_path, capsys, make, message):
    path = make(tmp_path / "model.ifc")
    assert main(["import-ifc", str(path), "-o", str(tmp_path / "o.toml")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and str(path) in err
    assert "Traceback" not in err
    with pytest.raises(IfcImportError, match=message):
        import_ifc(path)


def test_shipped_example_is_the_import_of_the_shipped_model():
    model = ROOT / "scenarios" / "ifc" / "example-frame.ifc"
    shipped = (ROOT / "scenarios" / "ifc" / "example-frame.toml").read_text()
    assert import_ifc(model, cranes=2).text == shipped
    s = load_scenario(ROOT / "scenarios" / "ifc" / "example-frame.toml")
    env = multicrane.parallel_env(s)
    assert run_episode(env, PrioritizedPlanner(env), seed=0)["success"]


@settings(max_examples=8, deadline=None, derandomize=True, database=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])  # fmt: skip
@given(
    bays=st.tuples(st.integers(1, 2), st.integers(0, 2), st.integers(1, 2)),
    span=st.sampled_from([2.0, 3.0, 4.5]),
    height=st.sampled_from([2.0, 3.0, 3.5]),
    cell=st.sampled_from([0.5, 1.0]),
    origin=st.tuples(*[st.floats(-50, 50, allow_nan=False)] * 3),
)
def test_random_frames_import_and_do_not_depend_on_where_the_model_lies(
    tmp_path, bays, span, height, cell, origin
):
    """Any small frame imports, loads and keeps every cell inside its element; moving the
    whole model changes nothing but the model point named in the description."""
    nx, ny, storeys = bays
    here = import_ifc(frame(nx, ny, storeys, span, height).write(tmp_path / "a.ifc"), cell=cell)
    moved = frame(nx, ny, storeys, span, height, origin=origin).write(tmp_path / "b.ifc")
    there = import_ifc(moved, cell=cell)
    a, b = here.scenario, there.scenario
    per_storey = (nx + 1) * (ny + 1) + nx * (ny + 1) + ny * (nx + 1)  # columns, beams
    assert a.n_components == per_storey * storeys
    assert [(c.kind, c.target, c.initial, c.supports) for c in a.components] == [
        (c.kind, c.target, c.initial, c.supports) for c in b.components
    ]
    assert (a.size, a.foundations, a.order) == (b.size, b.foundations, b.order)
    by_id = {cid: there.building.parts[i].element for i, cid in there.ids.items()}
    for c in b.components:
        e = by_id[c.id]
        for cell_ in geometry.pose_cells(*c.target):
            lo, hi = there.grid.cell_box(cell_)
            assert all(e.lo[k] - cell - 1e-6 <= lo[k] and hi[k] <= e.hi[k] + cell + 1e-6
                       for k in range(3))  # fmt: skip
