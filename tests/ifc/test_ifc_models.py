"""IFC models as people make them (``multicrane.ifc``): panels on the beams under them,
secondary beams on beams, units, schemas, nested placements, assemblies, mapped geometry, and
broken elements reported by name. Models come from ``multicrane.ifc.build``; needs the ``ifc``
extra (skipped without ifcopenshell)."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("ifcopenshell")

import multicrane  # noqa: E402
from multicrane.cli import main  # noqa: E402
from multicrane.core.codes import Kind  # noqa: E402
from multicrane.core.kinds import kind_spec  # noqa: E402
from multicrane.episodes.rollout import run_episode  # noqa: E402
from multicrane.ifc.build import FrameModel, frame  # noqa: E402
from multicrane.ifc.importer import import_ifc  # noqa: E402
from multicrane.scenario.loader import load_scenario  # noqa: E402
from multicrane.sim import geometry  # noqa: E402
from policies.prioritized import PrioritizedPlanner  # noqa: E402


def _finished(s, cranes: int | None = None) -> bool:
    env = multicrane.parallel_env(s, n_cranes=cranes) if cranes else multicrane.parallel_env(s)
    return run_episode(env, PrioritizedPlanner(env), seed=0)["success"]


def _under(s, i: int) -> set[int]:
    """The targets of a kind panel ``i`` may rest on, directly under its bottom row."""
    cells = geometry.pose_cells(*s.components[i].target)
    bottom = min(z for *_, z in cells)
    below = {(x, y, z - 1) for x, y, z in cells if z == bottom}
    rests_on = kind_spec(s.components[i].kind).rests_on
    return {j for j, c in enumerate(s.components) if c.kind in rests_on
            and below & set(geometry.pose_cells(*c.target))}  # fmt: skip


@pytest.fixture(scope="module")
def roof_frame(tmp_path_factory) -> Path:
    """The issue's model: a two-storey 3 x 2-bay steel frame with a roof slab on its beams."""
    return frame(3, 2, 2, roof=True).write(tmp_path_factory.mktemp("roof") / "frame.ifc")


@pytest.mark.parametrize("cranes", [1, 2, 3, 4])
def test_a_frame_with_a_roof_slab_imports_with_the_defaults_and_is_built(roof_frame, cranes):
    s = import_ifc(roof_frame, cranes=cranes).scenario
    kinds = [c.kind for c in s.components]
    assert (kinds.count(Kind.COLUMN), kinds.count(Kind.BEAM), kinds.count(Kind.SLAB)) == (24, 34, 1)
    assert _finished(s)


def test_the_roof_slab_rests_on_exactly_the_beams_under_it(roof_frame):
    result = import_ifc(roof_frame)
    s = result.scenario
    (slab,) = [i for i, c in enumerate(s.components) if c.kind == Kind.SLAB]
    supports = set(s.components[slab].supports)
    assert supports == _under(s, slab) and len(supports) == 17  # every top-storey beam
    assert all(s.components[j].id.startswith("b2-") for j in supports)
    assert not result.skipped


def test_the_cli_imports_the_roof_frame_with_its_defaults(roof_frame, tmp_path, capsys):
    out = tmp_path / "site.toml"
    assert main(["import-ifc", str(roof_frame), "-o", str(out)]) == 0
    assert "24 columns, 34 beams, 1 slabs" in capsys.readouterr().out
    assert [c.kind for c in load_scenario(out).components].count(Kind.SLAB) == 1


def test_the_help_says_what_the_default_does(capsys):
    with pytest.raises(SystemExit):
        main(["import-ifc", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "By default (--panels components) slabs, walls and plates" in text
    assert "become panel components resting on exactly" in text
    assert "issue" not in text.lower()


def test_walls_between_columns_are_trimmed_and_rest_on_the_ground_or_a_beam(tmp_path):
    s = import_ifc(frame(2, 1, 2, walls=True).write(tmp_path / "w.ifc")).scenario
    walls = [i for i, c in enumerate(s.components) if c.kind == Kind.WALL]
    assert len(walls) == 4
    for i in walls:
        (x0, y0, z0), (x1, y1, z1) = s.components[i].target
        assert (abs(x1 - x0) + 1, abs(z1 - z0) + 1) == (3, 2)  # between columns, under a beam
        if min(z0, z1) == 1:
            assert all((x, y0) in s.foundations for x in range(min(x0, x1), max(x0, x1) + 1))
        else:
            under = _under(s, i)
            assert set(s.components[i].supports) == under
            assert {s.components[j].kind for j in under} == {Kind.BEAM}
    assert _finished(s, 2)


def _reported(tmp_path: Path) -> tuple[Path, dict[str, str]]:
    """A portal frame with panels that cannot rest: a slab on columns only (beside the frame),
    a slab in the air and a wall over the beam's edge, each with its expected reason."""
    f = frame(1, 0, 1)
    st = f.model.by_type("IfcBuildingStorey")[0]
    for x in (10, 14):
        for y in (0, 4):
            f.column(st, x, y, 0, 3, name="free column")
    on_columns = f.box(st, (9.85, -0.15, 3.0), (14.15, 4.15, 3.2), name="on columns")
    in_air = f.box(st, (0, 0, 6), (4, 4, 6.2), name="in the air")
    partly = f.box(st, (1.9, -1.5, 3.0), (2.1, 1.5, 5.0), name="partly", ifc_class="IfcWall")
    reasons = {
        on_columns.GlobalId: "rests on no beam or wall (only on column targets)",
        in_air.GlobalId: "rests on nothing: no beam or wall target directly under it",
        partly.GlobalId: "partly supported: no slab or beam target under 2 of the 3 cells",
    }
    return f.write(tmp_path / "reported.ifc"), reasons


def test_panels_that_do_not_rest_are_reported_by_name_not_refused(tmp_path):
    path, reasons = _reported(tmp_path)
    result = import_ifc(path)
    got = {k.global_id: k for k in result.skipped}
    assert set(got) == set(reasons)
    for gid, reason in reasons.items():
        assert got[gid].reason.startswith(reason), got[gid].line()
        assert got[gid].ifc_type in ("IfcSlab", "IfcWall") and got[gid].name
        assert f"# {got[gid].line()}" in result.text
    assert result.scenario.n_components == 7  # the frame and the four free columns


def test_secondary_beams_rest_on_the_beams_they_frame_into(tmp_path):
    s = import_ifc(frame(2, 1, 1, secondary=2).write(tmp_path / "s.ifc")).scenario
    beams = [c for c in s.components if c.kind == Kind.BEAM]
    on_beams = [c for c in beams if all(s.components[j].kind == Kind.BEAM for j in c.supports)]
    assert len(beams) == 7 + 4 and len(on_beams) == 4
    for c in on_beams:
        assert len(c.supports) == 2  # the two primary beams at its ends
        for j in c.supports:
            assert geometry.touches(geometry.pose_cells(*c.target),
                                    geometry.pose_cells(*s.components[j].target))  # fmt: skip
            assert s.order.index(j) < s.order.index(s.components.index(c))
    assert _finished(s, 2)


def test_a_beam_lying_on_top_of_two_beams_rests_on_them(tmp_path):
    f = frame(1, 1, 1)
    st = f.model.by_type("IfcBuildingStorey")[0]
    on_top = f.linear(st, (2, -0.5, 3.15), (2, 4.5, 3.15), name="on top")
    result = import_ifc(f.write(tmp_path / "top.ifc"), cell=0.5)
    s = result.scenario
    (i,) = [i for i, cid in result.ids.items() if result.building.parts[i].element.name == "on top"]
    c = next(c for c in s.components if c.id == result.ids[i])
    assert [s.components[j].kind for j in c.supports] == [Kind.BEAM, Kind.BEAM]
    assert all(s.components[j].target[0][2] == c.target[0][2] - 1 for j in c.supports)
    assert on_top.GlobalId and _finished(s, 2)


WRITTEN = [
    dict(schema="IFC2X3"), dict(schema="IFC4X3"), dict(units="mm"),
    dict(nested=True, building_at=(250.0, -40.0, 1.5)), dict(mapped=True), dict(assemblies=True),
    dict(schema="IFC2X3", units="mm", nested=True, mapped=True, assemblies=True),
    dict(schema="IFC4X3", units="mm", nested=True, mapped=True, assemblies=True),
]  # fmt: skip


@pytest.mark.parametrize("written", WRITTEN, ids=lambda w: "-".join(map(str, w.values())))
def test_how_the_model_is_written_changes_nothing(tmp_path, written):
    """Schema, units, nested placements, mapped geometry and assemblies: the same building
    imports into the same site (only the description's model point may differ)."""
    shape = dict(secondary=1, walls=True, roof=True)
    plain = import_ifc(frame(2, 1, 2, **shape).write(tmp_path / "plain.ifc")).scenario
    result = import_ifc(frame(2, 1, 2, **shape, **written).write(tmp_path / "written.ifc"))
    s = result.scenario
    assert [(c.id, c.kind, c.target, c.initial, c.supports) for c in s.components] == [
        (c.id, c.kind, c.target, c.initial, c.supports) for c in plain.components
    ]
    assert (s.size, s.foundations, s.order) == (plain.size, plain.foundations, plain.order)
    assert not result.skipped  # assemblies are read as their parts, silently
    assert "'Level 2' (elevation 3 m)" in s.description  # metres, whatever the unit


def test_broken_elements_are_reported_and_loose_ones_imported(tmp_path):
    f = frame(1, 0, 1)
    st = f.model.by_type("IfcBuildingStorey")[0]
    bare = f.bare(st, "IfcBeam", name="no geometry")
    zero = f.linear(st, (2, 0, 3), (2, 0, 3), name="zero length")
    twin = f.column(st, 0, 4, 0, 3, name="twin")
    f.same_id(twin, f.model.by_type("IfcColumn")[0])
    loose = f.column(None, 8, 0, 0, 3, name="in no storey")
    result = import_ifc(f.write(tmp_path / "broken.ifc"))
    got = {k.name: k.reason for k in result.skipped}
    assert got == {
        "no geometry": "no body geometry",
        "zero length": got["zero length"],
        "twin": f"its GlobalId is also that of IfcColumn {twin.GlobalId} 'C1.1' (GlobalIds are "
        "unique)",
    }
    assert got["zero length"].startswith("no body geometry")
    ids = {result.building.parts[i].element.name: cid for i, cid in result.ids.items()}
    assert ids["in no storey"] == "c0-1" and ids["C1.1"] == "c1-1"
    assert bare.GlobalId and zero.GlobalId and loose.GlobalId


def test_an_element_part_of_an_imported_one_is_reported(tmp_path):
    import ifcopenshell.api.aggregate

    f = frame(1, 0, 1)
    (st,) = f.model.by_type("IfcBuildingStorey")
    wall = f.box(st, (0.15, -0.1, 0), (3.85, 0.1, 2.4), name="wall", ifc_class="IfcWall")
    layer = f.box(None, (0.15, -0.1, 0), (3.85, 0.0, 2.4), name="layer",
                  ifc_class="IfcBuildingElementPart")  # fmt: skip
    ifcopenshell.api.aggregate.assign_object(f.model, relating_object=wall, products=[layer])
    result = import_ifc(f.write(tmp_path / "parts.ifc"))
    (k,) = result.skipped
    assert (k.name, k.reason) == ("layer", f"a part of IfcWall {wall.GlobalId} 'wall', which is "
                                           "read as a whole")  # fmt: skip


def test_frame_model_options_are_written_as_asked(tmp_path):
    import ifcopenshell
    import ifcopenshell.util.unit

    f = FrameModel(schema="IFC4X3", units="mm", nested=True, mapped=True)
    st = f.storey("Level 1", 3.0)
    f.column(st, 0, 0, 3.0, 3.0)
    f.column(st, 4, 0, 3.0, 3.0)
    m = ifcopenshell.open(str(f.write(tmp_path / "o.ifc")))
    assert m.schema_identifier == "IFC4X3_ADD2"
    assert ifcopenshell.util.unit.calculate_unit_scale(m) == pytest.approx(0.001)
    assert m.by_type("IfcBuildingStorey")[0].Elevation == pytest.approx(3000.0)
    assert len(m.by_type("IfcMappedItem")) == 2 and len(m.by_type("IfcColumnType")) == 1
    storey = m.by_type("IfcBuildingStorey")[0]
    column = m.by_type("IfcColumn")[0]
    assert column.ObjectPlacement.PlacementRelTo.id() == storey.ObjectPlacement.id()


def test_shipped_roof_example_is_the_import_of_the_shipped_model():
    here = Path(__file__).resolve().parents[2] / "scenarios" / "ifc"
    assert import_ifc(here / "example-roof.ifc", cranes=2).text == (
        here / "example-roof.toml"
    ).read_text()
    s = load_scenario(here / "example-roof.toml")
    kinds = [c.kind for c in s.components]
    assert (kinds.count(Kind.COLUMN), kinds.count(Kind.BEAM), kinds.count(Kind.SLAB)) == (24, 46, 1)
    secondary = [c for c in s.components if c.kind == Kind.BEAM
                 and {s.components[j].kind for j in c.supports} == {Kind.BEAM}]  # fmt: skip
    assert len(secondary) == 12  # one per bay and storey
    assert _finished(s)


def test_obstacles_keep_a_shaft_over_every_column_and_beam(tmp_path):
    """Obstacles are there from the start: a plate across a portal's beam, or a roof over a
    storey with secondary beams (both found by the fuzz test), would wall targets in. Cells
    of a target or above one are left out, so each is lowered into place from above."""
    f = frame(1, 0, 1, span=2.0, height=2.5)
    st = f.model.by_type("IfcBuildingStorey")[0]
    f.box(st, (1.0, -1.0, 0.0), (1.1, 2.1, 3.1), name="plate", ifc_class="IfcPlate")
    crossed = import_ifc(f.write(tmp_path / "plate.ifc"), cell=0.5, panels="obstacles")
    roofed = import_ifc(frame(1, 2, 2, 5.5, 2.5, secondary=2, walls=True, roof=True)
                        .write(tmp_path / "roof.ifc"), cell=1.5, panels="obstacles")  # fmt: skip
    for result in (crossed, roofed):
        s = result.scenario
        assert s.obstacles and not result.skipped
        blocked = s.obstacle_cells()
        for c in s.components:
            assert not any((x, y, z + k) in blocked for x, y, z in geometry.pose_cells(*c.target)
                           for k in range(s.size[2]))  # fmt: skip
        assert _finished(s)


@pytest.mark.parametrize("yard", ["one", "two"])
def test_a_component_longer_than_the_building_is_wide_gets_a_yard_lane(tmp_path, yard):
    """A 45 m tower column beside a portal frame (found by the fuzz test: the yard's lanes
    grew in number, never in length, and the layout never ended)."""
    f = frame(1, 0, 1)
    f.column(None, 12, 4, 0, 45, name="tower")
    s = import_ifc(f.write(tmp_path / "tower.ifc"), cell=1.5, yard=yard).scenario
    tower = max(s.components, key=lambda c: c.length)
    assert tower.length == 30 and s.size[0] >= 30
    assert _finished(s)
