"""4D export: an episode's plan written into its building model as an IFC work schedule.

    from multicrane.ifc.schedule_4d import export_4d
    from multicrane.replay.record import EpisodeRecord
    export_4d(EpisodeRecord.load("site.json.gz"), "frame.ifc", "frame-4d.ifc",
              step_seconds=60, start=datetime(2027, 3, 1, 7))

Needs the ``ifc`` extra. The record must be an episode of a scenario imported from the model
(``multicrane import-ifc``): the scenario file keeps each component's element (type and
GlobalId) in its comments (``multicrane.ifc.scenario_text.elements_of``), and every one of
them must be in the model, with that type. The record is re-simulated (and checked) into the
cranes' timelines (``multicrane.replay.timeline``); :func:`component_tasks` reads from them,
per component assembled, in the order the record assembles them: the crane, its lift (from
the claim to the arrival on the target, breakdowns included) and its assembly (from the
assemble action to ``ASSEMBLED``). Time ``t`` (after step ``t``) is ``start + t *
step_seconds``.

:func:`export_4d` adds to a copy of the model, with ``ifcopenshell.api``: one
``IfcWorkSchedule`` (PLANNED) and in it one ``IfcTask`` (CONSTRUCTION, ``Identification`` the
component id) per assembled component, in assembly order, with two nested tasks, ``lift``
(MOVE) and ``assembly`` (INSTALLATION); each task has an ``IfcTaskTime`` (``ScheduleStart``,
``ScheduleFinish``, ``ScheduleDuration``, elapsed time). The element is the component task's
output (``sequence.assign_product``; a beam split into several components has one task per
part), the crane that lifts it an ``IfcConstructionEquipmentResource`` (ERECTING, one per
crane, named ``crane_k``) that the task operates on (``sequence.assign_process``), and each
support's assembly precedes the assembly it carries (``IfcRelSequence`` FINISH_START). The
times are set on the ``IfcTaskTime`` directly: ``sequence.edit_task_time`` would move them to
whole working days. IFC4 and IFC4X3 models only (IFC2X3 has no ``IfcTaskTime``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta
from pathlib import Path
from typing import TYPE_CHECKING

from multicrane.files import write_atomic
from multicrane.ifc.read import IfcImportError, open_model
from multicrane.ifc.scenario_text import elements_of
from multicrane.replay.timeline import ASSEMBLE, LIFT, Interval, timeline_of
from multicrane.sim.site import Site

if TYPE_CHECKING:
    from multicrane.core.schema import Scenario
    from multicrane.replay.record import EpisodeRecord

CRANE_RESOURCE = "IfcConstructionEquipmentResource"


class ScheduleExportError(ValueError):
    """A record or model that cannot be exported; the message names it and the problem."""


@dataclass(frozen=True)
class ComponentTask:
    """Component ``component`` (scenario order), lifted and assembled by ``crane``: its lift
    and its assembly as ``(start, finish)`` times in steps, and the components it rests on."""

    component: int
    crane: int
    lift: tuple[int, int]
    assembly: tuple[int, int]
    supports: tuple[int, ...]


@dataclass(frozen=True)
class Clock:
    """Steps to dates: time ``t`` is ``start + t * step_seconds``."""

    start: datetime
    step_seconds: float

    def at(self, t: int) -> datetime:
        return self.start + timedelta(seconds=t * self.step_seconds)


@dataclass(frozen=True)
class Export4d:
    """What :func:`export_4d` wrote: the file, the tasks (assembly order) and the clock."""

    path: Path
    tasks: list[ComponentTask]
    clock: Clock
    steps: int
    n_components: int
    n_cranes: int

    @property
    def sequences(self) -> int:
        """The sequence relations written: each support of each task that has a task."""
        done = {t.component for t in self.tasks}
        return sum(s in done for t in self.tasks for s in t.supports)


def component_tasks(
    events: Sequence[Sequence[tuple[str, int, int]]],
    intervals: Sequence[Interval],
    supports: Sequence[Sequence[int]],
) -> list[ComponentTask]:
    """One task per ``ASSEMBLED`` event of ``events`` (a record's, one list per step), in
    their order, its times read from the assembling crane's ``intervals``: the run of them
    that holds the component up to its assembly. ``supports[j]``: what component ``j``
    rests on."""
    lanes: dict[int, list[Interval]] = {}
    for iv in intervals:
        lanes.setdefault(iv.crane, []).append(iv)
    tasks = []
    for t, step in enumerate(events, 1):
        for etype, crane, comp in step:
            if etype == "ASSEMBLED":
                lane = lanes[crane]
                last = next(k for k, iv in enumerate(lane) if iv.start < t <= iv.end)
                first = last
                while first > 0 and lane[first - 1].component == comp:
                    first -= 1
                run = lane[first : last + 1]
                lifts = [iv for iv in run if iv.what == LIFT]
                arrival = lifts[-1].end if lifts else run[0].start
                begun = next((iv.start for iv in run if iv.what == ASSEMBLE), arrival)
                tasks.append(ComponentTask(comp, crane, (run[0].start, arrival), (begun, t),
                                           tuple(supports[comp])))  # fmt: skip
    return tasks


def export_4d(record: EpisodeRecord, model_path: str | Path, out_path: str | Path,
              step_seconds: float = 60.0, start: datetime | None = None) -> Export4d:  # fmt: skip
    """Write ``model_path`` with the record's plan as a work schedule to ``out_path``
    (module docstring); ``start`` defaults to 07:00 today. Every refusal is a
    :class:`ScheduleExportError` (or the record's ``RecordError``) in one line."""
    if not (math.isfinite(step_seconds) and step_seconds > 0):
        raise ScheduleExportError(f"step seconds {step_seconds!r}: must be a positive number")
    clock = Clock(start or datetime.now().replace(hour=7, minute=0, second=0, microsecond=0),
                  float(step_seconds))  # fmt: skip
    scenario = record.load_scenario()
    elements = _elements(scenario)
    try:
        model = open_model(model_path)
    except IfcImportError as exc:
        raise ScheduleExportError(str(exc)) from None
    if model.schema == "IFC2X3":
        raise ScheduleExportError(f"{model_path}: an IFC2X3 model has no IfcTaskTime for a 4D "
                                  "schedule: upgrade it to IFC4 first")  # fmt: skip
    products = _products(model, model_path, scenario, elements)
    supports = Site(scenario).target_supports  # imported targets are the components' own
    tasks = component_tasks(record.events, timeline_of(record), supports)
    _write_schedule(model, record, scenario, tasks, products, clock)
    out = Path(out_path)
    try:
        write_atomic(out, model.to_string())
    except OSError as exc:
        raise ScheduleExportError(f"{out}: cannot write the file ({exc.strerror})") from None
    return Export4d(out, tasks, clock, record.steps, scenario.n_components, record.n_cranes)


def _elements(scenario: Scenario) -> dict[str, tuple[str, str]]:
    """Each component's element, from the comments of the (hash-checked) scenario file."""
    text = Path(scenario.source).read_text(encoding="utf-8")
    elements = elements_of(text)
    if not elements:
        raise ScheduleExportError(f"scenario {scenario.name!r} ({scenario.source}) was not "
                                  "imported from an IFC model (multicrane import-ifc): its "
                                  "components name no IFC elements")  # fmt: skip
    missing = [cid for cid in scenario.ids if cid not in elements]
    if missing:
        raise ScheduleExportError(f"scenario {scenario.name!r}: {len(missing)} component(s) "
                                  f"name no IFC element ({', '.join(missing[:3])})")  # fmt: skip
    return elements


def _products(model, model_path, scenario: Scenario, elements: dict[str, tuple[str, str]]):
    """Each component's element in the model; refused unless every GlobalId is there with
    its type."""
    products, wrong = [], []
    for cid in scenario.ids:
        ifc_type, global_id = elements[cid]
        try:
            product = model.by_guid(global_id)
        except RuntimeError:  # IfcOpenShell: no instance with that GlobalId
            product = None
        if product is None or not product.is_a(ifc_type):
            wrong.append(f"{cid} ({ifc_type} {global_id})")
        products.append(product)
    if wrong:
        raise ScheduleExportError(f"{model_path} is not the model scenario {scenario.name!r} was "
                                  f"imported from: {len(wrong)} of {len(products)} elements "
                                  f"missing, e.g. {', '.join(wrong[:3])}")  # fmt: skip
    return products


def _write_schedule(model, record: EpisodeRecord, scenario: Scenario,
                    tasks: list[ComponentTask], products: list, clock: Clock) -> None:  # fmt: skip
    """The work schedule, tasks, crane resources and sequence relations (module docstring)."""
    import ifcopenshell.api.resource
    import ifcopenshell.api.sequence

    sequence = ifcopenshell.api.sequence
    who = f"{record.policy or 'a policy'}, seed {record.seed}"
    schedule = sequence.add_work_schedule(
        model, name=f"multicrane plan of {scenario.name} ({who})", predefined_type="PLANNED",
        start_time=clock.at(0))  # fmt: skip
    schedule.FinishTime = _ifc_time(clock.at(record.steps))
    schedule.Description = (f"{record.steps} steps of {clock.step_seconds:g} s, "
                            f"{record.n_cranes} crane(s), {len(tasks)} components assembled")
    cranes = [ifcopenshell.api.resource.add_resource(
        model, ifc_class=CRANE_RESOURCE, name=f"crane_{k}", predefined_type="ERECTING")
        for k in range(record.n_cranes)]  # fmt: skip
    timed = []  # (IfcTask, start, finish): times are set last, as assign_sequence cascades
    assemblies = {}
    for task in tasks:
        cid = scenario.ids[task.component]
        product = products[task.component]
        main = sequence.add_task(model, work_schedule=schedule, name=product.Name or cid,
                                 description=f"{cid}, lifted and assembled by crane_{task.crane}",
                                 identification=cid, predefined_type="CONSTRUCTION")  # fmt: skip
        sequence.assign_product(model, relating_product=product, related_object=main)
        sequence.assign_process(model, relating_process=main, related_object=cranes[task.crane])
        lift = sequence.add_task(model, parent_task=main, name=f"lift {cid}",
                                 predefined_type="MOVE")  # fmt: skip
        assembly = sequence.add_task(model, parent_task=main, name=f"assembly {cid}",
                                     predefined_type="INSTALLATION")  # fmt: skip
        for s in task.supports:  # a pre-built support has no task
            if s in assemblies:
                sequence.assign_sequence(model, relating_process=assemblies[s],
                                         related_process=assembly)  # fmt: skip
        assemblies[task.component] = assembly
        timed += [(main, task.lift[0], task.assembly[1]), (lift, *task.lift),
                  (assembly, *task.assembly)]  # fmt: skip
    for ifc_task, begin, finish in timed:
        _task_time(model, ifc_task, clock, begin, finish)


def _task_time(model, task, clock: Clock, start: int, finish: int) -> None:
    import ifcopenshell.api.sequence
    import ifcopenshell.util.date

    time = ifcopenshell.api.sequence.add_task_time(model, task=task)
    time.DurationType = "ELAPSEDTIME"
    time.ScheduleStart = _ifc_time(clock.at(start))
    time.ScheduleFinish = _ifc_time(clock.at(finish))
    time.ScheduleDuration = ifcopenshell.util.date.datetime2ifc(
        clock.at(finish) - clock.at(start), "IfcDuration")  # fmt: skip


def _ifc_time(moment: datetime) -> str:
    import ifcopenshell.util.date

    return ifcopenshell.util.date.datetime2ifc(moment, "IfcDateTime")


__all__ = ["Clock", "ComponentTask", "Export4d", "ScheduleExportError", "component_tasks",
           "export_4d"]  # fmt: skip
