"""The 4D export (``multicrane.ifc.schedule_4d``, ``multicrane export-4d``): a planned frame's
record written into its model as a work schedule, read back with IfcOpenShell and checked
against the record's own events; schema validation; the refusals. Needs the ``ifc`` extra."""

from __future__ import annotations

from datetime import datetime, timedelta
from pathlib import Path

import pytest

pytest.importorskip("ifcopenshell")

import ifcopenshell  # noqa: E402
import ifcopenshell.util.date  # noqa: E402
import ifcopenshell.util.sequence  # noqa: E402
import ifcopenshell.validate  # noqa: E402

import multicrane  # noqa: E402
from multicrane.cli import main  # noqa: E402
from multicrane.ifc.build import frame  # noqa: E402
from multicrane.ifc.importer import import_ifc  # noqa: E402
from multicrane.ifc.scenario_text import elements_of  # noqa: E402
from multicrane.ifc.schedule_4d import component_tasks  # noqa: E402
from multicrane.replay.record import EpisodeRecord, record_episode  # noqa: E402
from multicrane.replay.timeline import Interval  # noqa: E402
from multicrane.sim.site import Site  # noqa: E402
from policies.prioritized import PrioritizedPlanner  # noqa: E402

START = datetime(2027, 3, 1, 7, 0)
STEP = 30.0


@pytest.fixture(scope="module")
def planned(tmp_path_factory):
    """A two-storey portal frame (2 bays) imported for 2 cranes, planned by the prioritized
    planner into a record, and exported: (folder, model, scenario file, record, 4D file)."""
    d = tmp_path_factory.mktemp("frame4d")
    model = frame(2, 0, 2, name="frame").write(d / "frame.ifc")
    site = d / "frame.toml"
    site.write_text(import_ifc(model, cranes=2).text, encoding="utf-8")
    record = d / "frame.json.gz"
    assert main(["plan", str(site), "--policy", "prioritized", "--record", str(record)]) == 0
    out = d / "frame-4d.ifc"
    assert main(["export-4d", str(record), "--ifc", str(model), "-o", str(out),
                 "--step-seconds", str(STEP), "--start", START.isoformat()]) == 0  # fmt: skip
    return d, model, site, record, out


def _at(step: int) -> datetime:
    return START + timedelta(seconds=step * STEP)


def _times(task) -> tuple[datetime, datetime]:
    t = task.TaskTime
    return (ifcopenshell.util.date.ifc2datetime(t.ScheduleStart),
            ifcopenshell.util.date.ifc2datetime(t.ScheduleFinish))  # fmt: skip


def _expected(record: EpisodeRecord) -> list[dict]:
    """Per assembled component, in the record's order, from its events alone (no breakdowns,
    motion mode): lift from the start of the claim's step to the arrival, assembly from the
    start of the assemble action's step to ASSEMBLED."""
    seen: dict[int, dict] = {}
    order = []
    for t, step in enumerate(record.events, 1):
        for etype, crane, comp in step:
            row = seen.setdefault(comp, {"component": comp})
            if etype == "CLAIMED":
                row["lift"] = [t - 1, None]
            elif etype == "ARRIVED":
                row["lift"][1] = t
            elif etype == "ASSEMBLY_STARTED":
                row["assembly"] = [t - 1, None]
            elif etype == "ASSEMBLED":
                row["assembly"][1] = t
                row["crane"] = crane
                order.append(row)
    return order


def test_tasks_elements_times_order(planned):
    _, model, site, record_path, out = planned
    record = EpisodeRecord.load(record_path)
    scenario = multicrane.parallel_env(str(site)).scenario
    expected = _expected(record)
    assert len(expected) == scenario.n_components  # the plan finishes the frame
    elements = elements_of(site.read_text(encoding="utf-8"))
    f = ifcopenshell.open(str(out))
    (schedule,) = f.by_type("IfcWorkSchedule")
    roots = ifcopenshell.util.sequence.get_root_tasks(schedule)
    assert len(roots) == len(expected)  # one task per assembled component, nothing else
    assert [t.Identification for t in roots] == [scenario.ids[e["component"]] for e in expected]
    for task, e in zip(roots, expected, strict=True):
        cid = scenario.ids[e["component"]]
        (product,) = ifcopenshell.util.sequence.get_task_outputs(task)
        assert (product.is_a(), product.GlobalId) == elements[cid]
        lift, assembly = ifcopenshell.util.sequence.get_nested_tasks(task)
        assert lift.Name == f"lift {cid}" and assembly.Name == f"assembly {cid}"
        assert _times(lift) == (_at(e["lift"][0]), _at(e["lift"][1]))
        assert _times(assembly) == (_at(e["assembly"][0]), _at(e["assembly"][1]))
        assert _times(task) == (_at(e["lift"][0]), _at(e["assembly"][1]))
        assert task.TaskTime.ScheduleDuration == ifcopenshell.util.date.datetime2ifc(
            _at(e["assembly"][1]) - _at(e["lift"][0]), "IfcDuration")  # fmt: skip
        (crane,) = ifcopenshell.util.sequence.get_task_resources(task)
        assert crane.is_a("IfcConstructionEquipmentResource")
        assert crane.Name == f"crane_{e['crane']}"
    assert ifcopenshell.util.date.ifc2datetime(schedule.StartTime) == START
    assert ifcopenshell.util.date.ifc2datetime(schedule.FinishTime) == _at(record.steps)
    names = sorted(r.Name for r in f.by_type("IfcConstructionEquipmentResource"))
    assert names == ["crane_0", "crane_1"]
    # The model itself is unchanged: the same elements with the same GlobalIds.
    before = ifcopenshell.open(str(model))
    assert sorted(e.GlobalId for e in f.by_type("IfcElement")) == sorted(
        e.GlobalId for e in before.by_type("IfcElement"))  # fmt: skip


def test_support_sequences(planned):
    _, _, site, _, out = planned
    scenario = multicrane.parallel_env(str(site)).scenario
    supports = Site(scenario).target_supports
    f = ifcopenshell.open(str(out))
    (schedule,) = f.by_type("IfcWorkSchedule")
    assembly_of = {t.Identification: ifcopenshell.util.sequence.get_nested_tasks(t)[1]
                   for t in ifcopenshell.util.sequence.get_root_tasks(schedule)}  # fmt: skip
    count = 0
    for cid, assembly in assembly_of.items():
        before = {rel.RelatingProcess for rel in assembly.IsSuccessorFrom}
        want = {assembly_of[scenario.ids[s]] for s in supports[scenario.index_of(cid)]}
        assert before == want, cid
        assert all(rel.SequenceType == "FINISH_START" for rel in assembly.IsSuccessorFrom)
        for rel in assembly.IsSuccessorFrom:  # the plan keeps every relation
            assert _times(rel.RelatingProcess)[1] <= _times(assembly)[0]
        count += len(want)
    assert count == len(f.by_type("IfcRelSequence")) >= 8  # beams on columns, columns stacked


def test_schema_validation(planned):
    out = planned[-1]
    logger = ifcopenshell.validate.json_logger()
    ifcopenshell.validate.validate(str(out), logger)
    assert logger.statements == []


def test_elements_of_reads_back_the_import(tmp_path):
    model = frame(1, 1, 1, name="square").write(tmp_path / "square.ifc")
    result = import_ifc(model)
    parts = result.building.parts
    want = {cid: (parts[i].element.ifc_type, parts[i].element.global_id)
            for i, cid in result.ids.items()}  # fmt: skip
    assert elements_of(result.text) == want
    assert elements_of("[[components]]\nid = \"c1\"\n") == {}


def test_component_tasks_through_breakdowns():
    """A lift broken by a breakdown, an assembly paused by one, and the automatic mode's
    assembly on arrival (in no time)."""
    intervals = [
        Interval(0, 0, 2, "lift", 3),  # an earlier component
        Interval(0, 2, 3, "assemble", 3),
        Interval(0, 3, 5, "lift", 0),
        Interval(0, 5, 8, "down", 0),
        Interval(0, 8, 10, "lift", 0),
        Interval(0, 10, 12, "hold", 0),
        Interval(0, 12, 13, "assemble", 0),
        Interval(0, 13, 15, "down", 0),
        Interval(0, 15, 16, "assemble", 0),
        Interval(1, 0, 6, "wait"),
        Interval(1, 6, 16, "lift", 1),
    ]
    events = [[] for _ in range(16)]
    events[2].append(("ASSEMBLED", 0, 3))  # step 3
    events[15].append(("ASSEMBLED", 0, 0))  # step 16
    events[15].append(("ASSEMBLED", 1, 1))  # automatic mode: arrival and assembly, step 16
    supports = [(3,), (0,), (), ()]
    tasks = component_tasks(events, intervals, supports)
    assert [(t.component, t.crane, t.lift, t.assembly, t.supports) for t in tasks] == [
        (3, 0, (0, 2), (2, 3), ()),
        (0, 0, (3, 10), (12, 16), (3,)),
        (1, 1, (6, 16), (16, 16), (0,)),
    ]


def _refused(args: list[str], capsys) -> str:
    assert main(["export-4d", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("multicrane export-4d: error: ") and "\n" not in err
    return err


def test_refusals(planned, tmp_path, capsys):
    _, model, _, record, _ = planned
    out = str(tmp_path / "out.ifc")
    # A record of a scenario that was not imported from a model.
    env = multicrane.parallel_env("e2s2")
    shipped = tmp_path / "shipped.json.gz"
    record_episode(env, PrioritizedPlanner(env), seed=0).save(shipped)
    err = _refused([str(shipped), "--ifc", str(model), "-o", out], capsys)
    assert "was not imported from an IFC model" in err
    # Another model: the same frame built again has other GlobalIds.
    other = frame(2, 0, 2, name="frame").write(tmp_path / "other.ifc")
    err = _refused([str(record), "--ifc", str(other), "-o", out], capsys)
    assert "is not the model scenario 'frame' was imported from: 10 of 10 elements" in err
    old = frame(2, 0, 2, name="frame", schema="IFC2X3").write(tmp_path / "old.ifc")
    assert "IFC2X3" in _refused([str(record), "--ifc", str(old), "-o", out], capsys)
    # Missing files: the model, the record.
    err = _refused([str(record), "--ifc", str(tmp_path / "none.ifc"), "-o", out], capsys)
    assert err.endswith("none.ifc: no such file")
    err = _refused([str(tmp_path / "none.json.gz"), "--ifc", str(model), "-o", out], capsys)
    assert "none.json.gz" in err
    assert not Path(out).exists()
    err = _refused([str(record), "--ifc", str(model), "-o", str(tmp_path / "no" / "x.ifc")],
                   capsys)  # fmt: skip
    assert err.endswith("x.ifc: cannot write the file (No such file or directory)")
    err = _refused([str(record), "--ifc", str(model), "-o", out, "--step-seconds", "0"], capsys)
    assert "step seconds" in err
