"""The scenario file of an imported IFC model: the TOML text, with the model kept in comments.

``scenario_text`` writes the scenario with ``multicrane.scenario.writer.to_toml`` and adds what
the scenario format has no key for: a header naming the source file and the skip report (one
comment line per skipped element: type, GlobalId, name, reason), and above each component a
comment with the IFC element it came from (type, GlobalId, name, storey, and which part of a
split beam). The storeys are also in the ``description`` and in the component ids (``c2-5``:
a column of storey 2), so they survive loading. ``elements_of(text)`` reads each component's
element (type, GlobalId) back from those comments (the 4D export, ``multicrane.ifc.schedule_4d``).
Panel components (``PanelSpec``) are written in the panel schema of scenarios/README.md:
``kind = "slab"`` or ``"wall"``, ``initial`` and ``target`` two opposite corner cells of a
one-cell-thick rectangle, no ``length``, and ``supports`` naming the targets the panel rests
on (``multicrane.ifc.panels``).
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, replace

from multicrane.core.schema import Cell, Scenario
from multicrane.ifc.read import Skipped
from multicrane.ifc.snap import Building
from multicrane.scenario.writer import to_toml


@dataclass(frozen=True)
class PanelSpec:
    """A panel component as written to the file (cells on the site)."""

    id: str
    kind: str  # "slab" or "wall"
    initial: tuple[Cell, Cell]
    target: tuple[Cell, Cell]
    supports: tuple[str, ...]


def _s(text: str) -> str:
    return json.dumps(text, ensure_ascii=False)


def _cells(pose: tuple[Cell, Cell]) -> str:
    return "[" + ", ".join("[" + ", ".join(str(v) for v in c) + "]" for c in pose) + "]"


def _comment(text: str) -> str:
    return "# " + " ".join(text.split())  # one line, whatever the names hold


def describe(b: Building, schema: str, file_name: str, n_skipped: int,
             offset: tuple[int, int]) -> str:  # fmt: skip
    """The scenario's description: source, cell size, grid origin, storeys, skips."""
    storeys = sorted({(p.element.storey_elevation or 0.0, p.element.storey)
                      for p in b.parts if p.element.storey})  # fmt: skip
    names = "; ".join(f"{k} = {name!r} (elevation {elev:g} m)"
                      for k, (elev, name) in enumerate(storeys, 1))  # fmt: skip
    ox, oy, oz = b.grid.origin
    return (
        f"Imported from the {schema} model {file_name} by multicrane import-ifc, cell "
        f"{b.grid.cell:g} m; model point ({ox:g}, {oy:g}, {oz:g}) m is the lower corner of "
        f"site cell ({offset[0]}, {offset[1]}, 1). Storeys: {names or 'none'}. Component ids: "
        f"c (column), b (beam), s (slab), w (wall), then the storey number (0: in no storey) "
        f"and a running number. {n_skipped} element(s) skipped (listed in the file's comments)."
    )


def scenario_text(s: Scenario, b: Building, ids: dict[int, str], skipped: list[Skipped],
                  schema: str, file_name: str, panels: list[PanelSpec],
                  offset: tuple[int, int]) -> str:  # fmt: skip
    """The file of imported scenario ``s`` (module docstring)."""
    s = replace(s, description=describe(b, schema, file_name, len(skipped), offset))
    text = to_toml(s)
    by_id = {cid: b.parts[i] for i, cid in ids.items()}
    head = [f"# Imported from {file_name} ({schema}) by multicrane import-ifc.",
            f"# Skipped elements: {len(skipped)}."]  # fmt: skip
    head += [_comment("  " + k.line()) for k in skipped]
    lines: list[str] = []
    body = text.split("\n")
    for k, line in enumerate(body):
        if line.startswith("order = ") and panels:
            line = line[:-1] + ", " + ", ".join(_s(p.id) for p in panels) + "]"
        if line == "[[components]]":
            cid = json.loads(body[k + 1].removeprefix("id = "))
            lines.append(_origin(by_id[cid]))
        lines.append(line)
    for p in panels:
        lines += [_origin(by_id[p.id]), "[[components]]", f"id = {_s(p.id)}",
                  f"kind = {_s(p.kind)}", f"target = {_cells(p.target)}",
                  f"initial = {_cells(p.initial)}"]  # fmt: skip
        if p.supports:
            lines.append("supports = [" + ", ".join(_s(i) for i in p.supports) + "]")
        lines.append("")
    return "\n".join(head + [""] + lines)


# The comment above a component (``_origin``) starts with its element's type and GlobalId.
_ORIGIN = re.compile(r"# (Ifc[A-Za-z0-9]+) ([0-9A-Za-z_$]{22})(?: |$)")


def elements_of(text: str) -> dict[str, tuple[str, str]]:
    """Component id -> (IFC type, GlobalId) of the element it came from, read from the comment
    above each ``[[components]]`` of a file written by ``scenario_text`` (empty for a scenario
    file that was not imported)."""
    lines = text.split("\n")
    out = {}
    for k in range(1, len(lines) - 1):
        origin = _ORIGIN.match(lines[k - 1])
        if lines[k] == "[[components]]" and origin and lines[k + 1].startswith("id = "):
            out[json.loads(lines[k + 1].removeprefix("id = "))] = origin.groups()
    return out


def _origin(part) -> str:
    e = part.element
    storey = f", storey {e.storey!r}" if e.storey else ""
    piece = f", {part.piece}" if part.piece else ""
    return _comment(f"{e.ifc_type} {e.global_id} {e.name!r}{piece}{storey}")
