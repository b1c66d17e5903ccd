"""Scenario to TOML: the text of a scenario file that loads back into an equal Scenario.

``to_toml(scenario)`` writes every field the loader reads (``scenarios/README.md``), in one
fixed layout, so the same scenario always gives the same bytes. Loading the text with
``parse_scenario(text, source=scenario.source)`` gives a scenario equal to the original in
every field but ``sha256`` (the hash of the text), and equal in that too when the scenario
was itself parsed from ``to_toml``'s output (as ``multicrane.scenario.generator``'s are).
"""

from __future__ import annotations

import json
import math

from multicrane.core.kinds import kind_spec
from multicrane.core.schema import Pose, Scenario
from multicrane.scenario.events_table import events_lines

_DIRECTION_NAMES = {(1, 0, 0): "+x", (-1, 0, 0): "-x", (0, 1, 0): "+y", (0, -1, 0): "-y"}


def _str(text: str) -> str:
    return json.dumps(text, ensure_ascii=False)  # a JSON string is a TOML basic string


def _float(value: float) -> str:
    if not math.isfinite(value):
        raise ValueError(f"cannot write the non-finite number {value!r} to a scenario file")
    return repr(float(value))


def _cell(cell: tuple[int, ...]) -> str:
    return "[" + ", ".join(str(int(v)) for v in cell) + "]"


def _pose(pose: Pose) -> str:
    return f"[{_cell(pose[0])}, {_cell(pose[1])}]"


def _ids(s: Scenario, indices: tuple[int, ...]) -> str:
    return "[" + ", ".join(_str(s.components[i].id) for i in indices) + "]"


def to_toml(s: Scenario) -> str:
    """The scenario as the text of a format-1 scenario file (deterministic)."""
    out = ["format = 1", f"name = {_str(s.name)}", f"description = {_str(s.description)}", ""]
    x0, y0, x1, y1 = s.construction_area
    out += [
        "[site]",
        f"size = {_cell(s.size)}",
        f"construction_area = {{ min = [{x0}, {y0}], max = [{x1}, {y1}] }}",
        "foundations = [" + ", ".join(_cell(f) for f in s.foundations) + "]",
        "obstacles = ["
        + ", ".join(f"{{ min = {_cell(b.lo)}, max = {_cell(b.hi)} }}" for b in s.obstacles)
        + "]",
        "",
        "[rules]",
        f"cranes = {s.cranes}",
        f"step_limit = {s.step_limit}",
        f"interchangeable_targets = {'true' if s.interchangeable_targets else 'false'}",
        f"assembly_steps = {s.assembly_steps}",
    ]
    if s.beam_lift_z is not None:
        out.append(f"beam_lift_z = {s.beam_lift_z}")
    out += [f"order = {_ids(s, s.order)}", ""]
    r = s.reward
    out += [
        "[reward]",
        f"completion = {_float(r.completion)}",
        f"move_limit = {r.move_limit}",
        f"over_limit_cost = {_float(r.over_limit_cost)}",
        f"step_cost = {_float(r.step_cost)}",
        "",
    ]
    if s.random_start is not None:
        rs = s.random_start
        bands = ", ".join(
            f"{{ x = [{b.x[0]}, {b.x[1]}], y = [{b.y[0]}, {b.y[1]}] }}" for b in rs.bands
        )
        dirs = ", ".join(_str(_DIRECTION_NAMES[tuple(d)]) for d in rs.directions)
        out += ["[random_start]", f"z = {rs.z}", f"bands = [{bands}]", f"directions = [{dirs}]", ""]
    for spec in s.crane_specs:
        out += ["[[crane]]", f"base = {_cell(spec.base)}", f"radius = {_float(spec.radius)}", ""]
    for c in s.components:
        kind = kind_spec(c.kind)
        out += [
            "[[components]]",
            f"id = {_str(c.id)}",
            f"kind = {_str(kind.name)}",
            *([] if kind.panel else [f"length = {c.length}"]),
            f"target = {_pose(c.target)}",
        ]
        if c.initial is not None:
            out.append(f"initial = {_pose(c.initial)}")
        if c.supports:
            out.append(f"supports = {_ids(s, c.supports)}")
        if c.prebuilt:
            out.append("prebuilt = true")
        if c.prebuilt_on:
            out.append(f"prebuilt_on = {_ids(s, c.prebuilt_on)}")
        out.append("")
    if s.events is not None:
        out += events_lines(s.events, s.ids)
    return "\n".join(out)
