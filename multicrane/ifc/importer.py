"""IFC to scenario: a building model read, snapped to the grid and laid out as a site.

Needs the ``ifc`` extra (``pip install 'multicrane[ifc]'``). ``import_ifc(path, cell=1.0,
yard="one", cranes=1, panels="components")`` reads the model (``multicrane.ifc.read``), snaps
its columns, beams and panels to cells of ``cell`` metres (``multicrane.ifc.snap``), lays
the yard out with the generator's rule (``multicrane.scenario.generator_yard``: components
lying in lanes at ``z = 1`` on one, two or all sides of a construction area one cell larger
than the building's plan extent), writes the file (``multicrane.ifc.scenario_text``) and loads
it with the strict loader (every load check, solvability included). The site is as high as
the building plus its longest column (a standing column can be carried over the finished
building), and beams are lifted to the top of the site, as in generated scenarios. The list
order is buildable: columns and beams by height (columns before the beams at their top,
primary beams before the secondary ones on them), then the panels, lowest first.

Slabs, walls and plates (``panels``, ``multicrane.ifc.panels``): ``"components"`` (the
default: panel components ``kind = "slab"`` / ``"wall"`` given by two opposite corner cells,
resting on exactly the targets under them, lying flat in an extra yard strip; a wall on the
ground gets a foundation strip under it), ``"obstacles"`` (their cells, less those of column
and beam targets and above them, become obstacle boxes) or ``"skip"`` (listed in the skip
report).
Everything left out is in ``IfcImport.skipped`` with its type, GlobalId, name and reason.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, replace
from pathlib import Path

from multicrane.core.kinds import VERTICAL_BAR, kind_named, kind_spec
from multicrane.core.schema import (
    Box,
    Cell,
    ComponentSpec,
    RewardSpec,
    Scenario,
    ScenarioError,
)
from multicrane.ifc.panels import Panels, panel_yard, place_panels, wall_strips
from multicrane.ifc.read import IfcImportError, Skipped, read_ifc
from multicrane.ifc.scenario_text import scenario_text
from multicrane.ifc.snap import Building, Grid, Part, snap
from multicrane.scenario import generator_yard
from multicrane.scenario.limits import MAX_SITE_CELLS
from multicrane.scenario.loader import parse_scenario

PANEL_MODES = ("components", "obstacles", "skip")
YARDS = ("one", "two", "around")
MAX_HEIGHT = 64


@dataclass
class IfcImport:
    """An imported model: the file text, its scenario (None when not loaded) and the report."""

    text: str
    scenario: Scenario | None
    building: Building
    ids: dict[int, str]  # part index (Building.parts) -> component id
    skipped: list[Skipped]
    schema: str
    obstacle_parts: list[int]  # parts that became obstacles
    grid: Grid  # where the site's cells lie in the model (metres)


def import_ifc(path: str | Path, cell: float = 1.0, yard: str = "one", cranes: int = 1,
               panels: str = "components", load: bool = True) -> IfcImport:  # fmt: skip
    """The scenario of the IFC model at ``path`` (module docstring). ``load=False`` returns
    the text without loading it (``scenario`` is None)."""
    _check_options(cell, yard, panels, cranes)
    name = Path(path).stem
    schema, building, skipped = _read_and_snap(path, cell)
    members = [i for i, p in enumerate(building.parts) if not kind_named(p.kind).panel]
    if not members:
        raise IfcImportError(f"{path}: no column or beam could be placed on the grid")
    use = place_panels(building, members, panels, skipped)
    ids = _ids(building, members + [i for i, _ in use.specs])
    comps, order = _components(building, members, ids)
    height = _height(path, cell, comps, use)
    kept = [building.parts[i] for i in members + use.obstacle_parts + [i for i, _ in use.specs]]
    site = _lay_out(kept, comps, height, yard)
    ox, oy = site.offset
    comps = [replace(c, target=_shift(c.target, ox, oy), initial=site.starts[k])
             for k, c in enumerate(comps)]  # fmt: skip
    obstacles = [Box(_move(b.lo, ox, oy), _move(b.hi, ox, oy)) for b in use.obstacles]
    size = (site.size[0], site.size[1], height)
    placed_panels, size = panel_yard(use.specs, ids, ox, oy, size)
    if size[0] * size[1] * size[2] > MAX_SITE_CELLS:
        raise IfcImportError(f"{path}: the site would have {size[0] * size[1] * size[2]} cells "
                             f"({size[0]} x {size[1]} x {size[2]}) at cell {cell} m; at most "
                             f"{MAX_SITE_CELLS}: choose a larger --cell")  # fmt: skip
    n = len(comps) + len(placed_panels)
    scenario = Scenario(
        name=name, description="", source=str(path), sha256="", size=size,
        construction_area=site.area,
        foundations=tuple(dict.fromkeys([(x + ox, y + oy) for x, y in building.foundations]
                                        + wall_strips(placed_panels))),
        obstacles=tuple(sorted(obstacles, key=lambda b: (b.lo, b.hi))),
        components=tuple(comps), order=tuple(order), cranes=cranes,
        step_limit=max(1000, 150 * n), interchangeable_targets=False, assembly_steps=1,
        beam_lift_z=height, reward=RewardSpec(), random_start=None,
    )  # fmt: skip
    text = scenario_text(scenario, building, ids, skipped, schema, Path(path).name,
                         placed_panels, site.offset)  # fmt: skip
    g = building.grid
    grid = Grid(g.cell, (g.origin[0] - ox * g.cell, g.origin[1] - oy * g.cell, g.origin[2]))
    result = IfcImport(text, None, building, ids, skipped, schema, use.obstacle_parts, grid)
    if load:
        try:
            result.scenario = parse_scenario(text, source=f"{path} (imported)", default_name=name)
        except ScenarioError as exc:
            hint = " (try --panels skip)" if use.obstacle_parts else ""
            raise IfcImportError(f"the imported site does not load: {exc}{hint}") from None
    return result


def _check_options(cell: float, yard: str, panels: str, cranes: int) -> None:
    if not cell > 0:
        raise IfcImportError(f"cell size {cell!r}: must be a positive number of metres")
    if yard not in YARDS:
        raise IfcImportError(f"yard {yard!r}: must be one of {', '.join(YARDS)}")
    if panels not in PANEL_MODES:
        raise IfcImportError(f"panels {panels!r}: must be one of {', '.join(PANEL_MODES)}")
    if not isinstance(cranes, int) or cranes < 1:
        raise IfcImportError(f"cranes {cranes!r}: must be an integer >= 1")


def _read_and_snap(path: str | Path, cell: float) -> tuple[str, Building, list[Skipped]]:
    """The model's schema, its building on the grid, and every element left out so far."""
    schema, elements, skipped = read_ifc(path, cell)
    if not any(e.role == "column" for e in elements):
        found = sum(s.ifc_type == "IfcColumn" for s in skipped)
        what = f"none of its {found} IfcColumn elements is usable" if found else "no IfcColumn"
        raise IfcImportError(f"{path}: {schema} model with {what}: a building is imported from "
                             "its columns (they stand on the foundations)")  # fmt: skip
    building = snap(elements, cell)
    return schema, building, skipped + building.skipped


def _height(path: str | Path, cell: float, comps: list[ComponentSpec], use: Panels) -> int:
    """The site's height: the building's top plus its longest column (refused over
    ``MAX_HEIGHT``)."""
    top = max(c.target[1][2] for c in comps)
    top = max([top] + [p.hi[2] for _, p in use.specs] + [b.hi[2] for b in use.obstacles])
    height = top + max(c.length for c in comps if kind_spec(c.kind).shape == VERTICAL_BAR)
    if height > MAX_HEIGHT:
        raise IfcImportError(f"{path}: the site would be {height} cells high at cell {cell} m "
                             f"(at most {MAX_HEIGHT}): choose a larger --cell")  # fmt: skip
    return height


def _lay_out(kept: list[Part], comps: list[ComponentSpec], height: int, yard: str):
    """The generator's yard around the plan extent of what is imported."""
    width = max(p.hi[0] for p in kept) + 1  # the plan extent of what is imported
    depth = max(p.hi[1] for p in kept) + 1
    params = {"bays_x": width - 1, "bays_y": depth - 1, "span": 1, "storeys": 1,
              "column_height": height - 1, "yard": yard, "random_start": False,
              "obstacles": 0}  # fmt: skip
    return generator_yard.lay_out(comps, params, random.Random(0))


def _ids(b: Building, indices: list[int]) -> dict[int, str]:
    """Component ids: kind letter, storey number (1 = lowest storey; 0: none), running number."""
    storeys = sorted({(p.element.storey_elevation or 0.0, p.element.storey)
                      for p in b.parts if p.element.storey})  # fmt: skip
    number = {name: k for k, (_, name) in enumerate(storeys, 1)}
    count: dict[str, int] = {}
    out: dict[int, str] = {}
    for i in indices:
        p = b.parts[i]
        prefix = f"{p.kind[0]}{number.get(p.element.storey, 0)}"
        count[prefix] = count.get(prefix, 0) + 1
        out[i] = f"{prefix}-{count[prefix]}"
    return out


def _components(b: Building, members: list[int], ids: dict[int, str]):
    """Column and beam specs (grid cells), and a buildable list order of all components."""
    index = {i: k for k, i in enumerate(members)}
    comps = []
    for i in members:
        p = b.parts[i]
        kind = kind_named(p.kind).code
        length = max(abs(h - lo) for lo, h in zip(p.lo, p.hi, strict=True)) + 1
        comps.append(ComponentSpec(ids[i], kind, length, None, (p.lo, p.hi),
                                   tuple(index[j] for j in p.supports), False, ()))  # fmt: skip
    order = sorted(range(len(comps)), key=lambda k: (comps[k].target[0][2], comps[k].kind, k))
    return comps, order


def _shift(pose, ox: int, oy: int):
    return tuple(_move(c, ox, oy) for c in pose)


def _move(c: Cell, ox: int, oy: int) -> Cell:
    return (c[0] + ox, c[1] + oy, c[2])
