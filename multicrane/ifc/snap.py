"""Snapping IFC elements to the voxel grid: column and beam targets, supports, foundations, panels.

``snap(elements, cell)`` turns the world boxes of ``multicrane.ifc.read`` into cells of
``cell`` metres. The grid is fixed by the first column: its centre lies in the middle of a cell,
and the lowest column base is the ground (the top of ``z = 0``). Rules:

- a **column** takes the cell column under its plan centre, from the grid plane nearest its
  base to the plane nearest its top; at the ground it gets a foundation, above the ground it
  must stand on a column target (else it is skipped: "stands on nothing");
- a **beam** (a lying member) takes the cell row through its centre, at the height whose cell
  top is nearest its top face, from the plane nearest one end to the plane nearest the other;
  the cells of column targets are cut out of it (a beam through a column is split into one
  part per span) and each part rests on the column targets it touches (its ``supports``); a
  part that touches no column is skipped (the scenario format has beams resting on columns);
- a **panel** (slab, wall, plate) takes the cells between the planes nearest its faces (at
  least the cell of its centre along a thin side); a slab is thinnest along z, a wall across.

A member shorter than one cell after snapping, or overlapping one already placed, is skipped
with the reason. The result's cells are indices of the grid ``Grid``; the same box in the world
is ``Grid.cell_box``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from multicrane.core.kinds import (
    HORIZONTAL_BAR,
    HORIZONTAL_PANEL,
    VERTICAL_BAR,
    VERTICAL_PANEL,
    ifc_kind,
)
from multicrane.core.schema import Cell
from multicrane.ifc.read import Element, Skipped
from multicrane.sim import geometry

_EPS = 1e-6


@dataclass(frozen=True)
class Grid:
    """World position of the cells: cell ``(i, j, k)`` spans ``origin + (i, j, k - 1) * cell``
    to ``origin + (i + 1, j + 1, k) * cell`` (metres)."""

    cell: float
    origin: tuple[float, float, float]

    def cell_box(self, c: Cell) -> tuple[tuple[float, ...], tuple[float, ...]]:
        s, (ox, oy, oz) = self.cell, self.origin
        lo = (ox + c[0] * s, oy + c[1] * s, oz + (c[2] - 1) * s)
        return lo, tuple(v + s for v in lo)

    def plane(self, v: float, axis: int) -> int:
        """The index of the grid plane nearest ``v`` (metres) along ``axis``."""
        return math.floor((v - self.origin[axis]) / self.cell + 0.5 + _EPS)

    def inside(self, v: float, axis: int) -> int:
        """The index of the cell holding ``v`` (metres) along ``axis``."""
        return math.floor((v - self.origin[axis]) / self.cell + _EPS)


@dataclass(frozen=True)
class Part:
    """One component made from an element (a beam split at columns gives several)."""

    element: Element
    kind: str  # its kind's name (multicrane.core.kinds.ifc_kind): "column", "beam", "slab", "wall"
    lo: Cell  # column and beam: node 1 (a column's bottom); panel: one corner
    hi: Cell  # column and beam: node 2 (a column's top); panel: the opposite corner
    supports: tuple[int, ...] = ()  # indices into Building.parts
    piece: str = ""  # "part 2 of 3" for a split beam

    def cells(self) -> list[Cell]:
        return [(x, y, z) for x in range(self.lo[0], self.hi[0] + 1)
                for y in range(self.lo[1], self.hi[1] + 1)
                for z in range(self.lo[2], self.hi[2] + 1)]  # fmt: skip


@dataclass
class Building:
    """The snapped building: parts (columns, beams, then panels), foundations, skips."""

    grid: Grid
    parts: list[Part] = field(default_factory=list)
    foundations: list[tuple[int, int]] = field(default_factory=list)
    skipped: list[Skipped] = field(default_factory=list)


def _skip(e: Element, reason: str) -> Skipped:
    return Skipped(e.ifc_type, e.global_id, e.name, reason)


def snap(elements: list[Element], cell: float) -> Building:
    """The elements on a grid of ``cell`` metres (module docstring); needs one column."""
    columns = [e for e in elements if e.role == "column"]
    if not columns:
        raise ValueError("snap needs at least one column")
    first = columns[0]
    x0 = (first.lo[0] + first.hi[0]) / 2 - cell / 2
    y0 = (first.lo[1] + first.hi[1]) / 2 - cell / 2
    z0 = min(c.lo[2] for c in columns)
    b = Building(Grid(cell, (x0, y0, z0)))
    occupied: dict[Cell, int] = {}  # cell -> the index of the part that takes it
    _snap_columns(b, occupied, columns)
    column_cells = dict(occupied)
    for e in (e for e in elements if e.role == "beam"):
        _snap_beam(b, occupied, column_cells, e)
    for e in (e for e in elements if e.role == "panel"):
        _snap_panel(b, e)
    return _to_origin(b)


def _add(b: Building, occupied: dict[Cell, int], part: Part) -> int | None:
    """Place ``part`` (its index in ``b.parts``), or skip it when it overlaps a placed one."""
    clash = next((occupied[c] for c in part.cells() if c in occupied), None)
    if clash is not None:
        other = b.parts[clash].element
        b.skipped.append(_skip(part.element, f"{part.piece + ': ' if part.piece else ''}"
                               f"overlaps {other.ifc_type} {other.global_id} "
                               f"{other.name!r} at the cell size"))  # fmt: skip
        return None
    b.parts.append(part)
    for c in part.cells():
        occupied[c] = len(b.parts) - 1
    return len(b.parts) - 1


def _snap_columns(b: Building, occupied: dict[Cell, int], columns: list[Element]) -> None:
    """Columns, lowest first: each on a foundation or on a column target below it."""
    grid = b.grid
    for e in sorted(columns, key=lambda e: e.lo[2]):
        x, y = grid.inside((e.lo[0] + e.hi[0]) / 2, 0), grid.inside((e.lo[1] + e.hi[1]) / 2, 1)
        bottom, top = grid.plane(e.lo[2], 2) + 1, grid.plane(e.hi[2], 2)
        if top < bottom:
            b.skipped.append(_skip(e, f"too short for the cell size ({e.hi[2] - e.lo[2]:.2f} m "
                                      f"tall, cell {grid.cell} m)"))  # fmt: skip
            continue
        below = occupied.get((x, y, bottom - 1))
        if bottom > 1 and (below is None or b.parts[below].kind != "column"):
            b.skipped.append(_skip(e, "stands on nothing: no column below it and not at the "
                                      "lowest column base"))  # fmt: skip
            continue
        column = ifc_kind(e.ifc_type, VERTICAL_BAR).name
        placed = _add(b, occupied, Part(e, column, (x, y, bottom), (x, y, top))) is not None
        if placed and bottom == 1 and (x, y) not in b.foundations:
            b.foundations.append((x, y))


def _snap_beam(
    b: Building, occupied: dict[Cell, int], column_cells: dict[Cell, int], e: Element
) -> None:
    """A beam, cut at column targets, each part resting on the columns it touches."""
    grid = b.grid
    axis = 0 if e.hi[0] - e.lo[0] >= e.hi[1] - e.lo[1] else 1
    other = 1 - axis
    z = grid.plane(e.hi[2], 2)
    across = grid.inside((e.lo[other] + e.hi[other]) / 2, other)
    first_cell, last_cell = grid.plane(e.lo[axis], axis), grid.plane(e.hi[axis], axis) - 1
    if z < 1:
        b.skipped.append(_skip(e, "lies below the lowest column base"))
        return

    def at(a: int) -> Cell:
        return (a, across, z) if axis == 0 else (across, a, z)

    runs = _runs_between(range(first_cell, last_cell + 1), lambda a: at(a) in column_cells)
    if not runs:
        length = e.hi[axis] - e.lo[axis]
        b.skipped.append(_skip(e, f"too short for the cell size ({length:.2f} m between "
                                  f"columns, cell {grid.cell} m)"))  # fmt: skip
        return
    for n, run in enumerate(runs, 1):
        piece = f"part {n} of {len(runs)}" if len(runs) > 1 else ""
        cells = [at(a) for a in run]
        supports = sorted({column_cells[c] for c in column_cells
                           if geometry.touches(cells, [c])})  # fmt: skip
        if not supports:
            b.skipped.append(_skip(e, f"{piece + ': ' if piece else ''}rests on no column "
                                      "(beams rest on columns in the scenario format)"))
            continue
        beam = ifc_kind(e.ifc_type, HORIZONTAL_BAR).name
        _add(b, occupied, Part(e, beam, at(run[0]), at(run[-1]), tuple(supports), piece))


def _runs_between(cells: range, cut) -> list[list[int]]:
    """The runs of consecutive ``cells`` between those where ``cut`` holds (none empty)."""
    runs: list[list[int]] = []
    for a in cells:
        if cut(a):
            runs.append([])
        elif runs and runs[-1]:
            runs[-1].append(a)
        else:
            runs.append([a])
    return [r for r in runs if r]


def _snap_panel(b: Building, e: Element) -> None:
    """A panel: a box of cells, one cell at least along each side."""
    grid = b.grid
    lo, hi = [], []
    for axis in range(3):
        a, c = grid.plane(e.lo[axis], axis), grid.plane(e.hi[axis], axis) - 1
        if c < a:
            a = c = grid.inside((e.lo[axis] + e.hi[axis]) / 2, axis)
        shift = 1 if axis == 2 else 0
        lo.append(a + shift)
        hi.append(c + shift)
    if hi[2] < 1:
        b.skipped.append(_skip(e, "lies in the ground (below the lowest column base)"))
        return
    lo[2] = max(lo[2], 1)
    extent = [h - a for a, h in zip(e.lo, e.hi, strict=True)]
    flat = extent[2] <= min(extent[0], extent[1])
    kind = ifc_kind(e.ifc_type, HORIZONTAL_PANEL if flat else VERTICAL_PANEL).name
    b.parts.append(Part(e, kind, tuple(lo), tuple(hi)))  # type: ignore[arg-type]


def _to_origin(b: Building) -> Building:
    """The same building shifted so that its plan extent starts at cell (0, 0)."""
    if not b.parts:
        return b
    dx = min(min(p.lo[0], p.hi[0]) for p in b.parts)
    dy = min(min(p.lo[1], p.hi[1]) for p in b.parts)

    def move(c: Cell) -> Cell:
        return (c[0] - dx, c[1] - dy, c[2])

    ox, oy, oz = b.grid.origin
    grid = Grid(b.grid.cell, (ox + dx * b.grid.cell, oy + dy * b.grid.cell, oz))
    parts = [Part(p.element, p.kind, move(p.lo), move(p.hi), p.supports, p.piece) for p in b.parts]
    foundations = [(x - dx, y - dy) for x, y in b.foundations]
    return Building(grid, parts, foundations, b.skipped)
