"""Snapping IFC elements to the voxel grid: column and beam targets, supports, foundations, panels.

``snap(elements, cell)`` turns the world boxes of ``multicrane.ifc.read`` into cells of
``cell`` metres. The grid is fixed by the first column: its centre lies in the middle of a cell,
and the lowest column base is the ground (the top of ``z = 0``). Rules:

- a **column** takes the cell column under its plan centre, from the grid plane nearest its
  base to the plane nearest its top; at the ground it gets a foundation, above the ground it
  must stand on a column target (else it is skipped: "stands on nothing");
- a **beam** (a lying member) takes the cell row through its centre, at the height whose cell
  top is nearest its top face, from the plane nearest one end to the plane nearest the other.
  Beams are placed in rounds: in the first, each part that touches a column target rests on
  the columns it touches (its ``supports``); in each later one, a part rests on the columns
  it touches and the beams at its ends or under it, placed in earlier rounds and not above
  it, so a secondary beam rests on the beams it frames into, and a beam on those under it.
  The cells of columns and of beams placed across it are cut out of a beam (a beam through a
  column or a girder is split into one part per span, "part 2 of 3"); a part that overlaps a
  beam along the same line is skipped, and so is one that nothing supports ("rests on no
  column or beam");
- a **panel** (slab, wall, plate) takes the cells between the planes nearest its faces (at
  least the cell of its centre along a thin side); a slab is thinnest along z, a wall across.

A member shorter than one cell after snapping, or a column overlapping one already placed, is
skipped with the reason. The result's cells are indices of the grid ``Grid``; the same box in
the world is ``Grid.cell_box``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from multicrane.core.kinds import (
    HORIZONTAL_BAR,
    HORIZONTAL_PANEL,
    VERTICAL_BAR,
    VERTICAL_PANEL,
    ifc_kind,
    kind_named,
)
from multicrane.core.schema import Cell
from multicrane.ifc.read import Element, Skipped

_EPS = 1e-6
_FACES = ((1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1))


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
    _snap_beams(b, occupied, [e for e in elements if e.role == "beam"])
    for e in (e for e in elements if e.role == "panel"):
        _snap_panel(b, e)
    return _to_origin(b)


def _put(b: Building, occupied: dict[Cell, int], part: Part) -> int:
    """Place ``part`` on free cells; its index in ``b.parts``."""
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
        part = Part(e, ifc_kind(e.ifc_type, VERTICAL_BAR).name, (x, y, bottom), (x, y, top))
        clash = next((occupied[c] for c in part.cells() if c in occupied), None)
        if clash is not None:
            other = b.parts[clash].element
            b.skipped.append(_skip(e, f"overlaps {other.ifc_type} {other.global_id} "
                                      f"{other.name!r} at the cell size"))  # fmt: skip
            continue
        _put(b, occupied, part)
        if bottom == 1 and (x, y) not in b.foundations:
            b.foundations.append((x, y))


@dataclass
class _Piece:
    """A run of cells of one beam, not placed yet: ``cells`` along ``axis`` at ``(across, z)``."""

    element: Element
    axis: int
    across: int
    z: int
    cells: list[int]

    def at(self, a: int) -> Cell:
        return (a, self.across, self.z) if self.axis == 0 else (self.across, a, self.z)


def _beam_line(b: Building, e: Element) -> _Piece | None:
    """The cells of a lying member before any cut (None, and the skip, below the ground)."""
    grid = b.grid
    axis = 0 if e.hi[0] - e.lo[0] >= e.hi[1] - e.lo[1] else 1
    other = 1 - axis
    z = grid.plane(e.hi[2], 2)
    if z < 1:
        b.skipped.append(_skip(e, "lies below the lowest column base"))
        return None
    across = grid.inside((e.lo[other] + e.hi[other]) / 2, other)
    first, last = grid.plane(e.lo[axis], axis), grid.plane(e.hi[axis], axis) - 1
    return _Piece(e, axis, across, z, list(range(first, last + 1)))


def _snap_beams(b: Building, occupied: dict[Cell, int], beams: list[Element]) -> None:
    """Beams in rounds: a piece rests on the columns and beams placed in earlier rounds that
    it touches (round one: columns only), so secondary beams follow the beams they rest on.
    Each piece is cut at the cells of columns and of the beams across it."""
    pending: list[_Piece] = []
    for e in beams:
        line = _beam_line(b, e)
        if line is None:
            continue
        if all(line.at(a) in occupied for a in line.cells):  # only columns are placed yet
            length = e.hi[line.axis] - e.lo[line.axis]
            where = "between columns" if line.cells else "long"
            b.skipped.append(_skip(e, f"too short for the cell size ({length:.2f} m {where}, "
                                      f"cell {b.grid.cell} m)"))  # fmt: skip
        else:
            pending.append(line)
    outcomes: list[tuple[_Piece, int | str]] = []  # each piece: its part index, or why not
    while pending:
        before, left, placed = dict(occupied), [], False
        for piece in pending:
            runs = _cut(b, piece, occupied)
            if isinstance(runs, str):
                outcomes.append((piece, runs))
                continue
            for run in runs:
                supports = _beam_supports(b, before, run)
                if supports:
                    kind = ifc_kind(run.element.ifc_type, HORIZONTAL_BAR).name
                    part = Part(run.element, kind, run.at(run.cells[0]), run.at(run.cells[-1]),
                                supports)  # fmt: skip
                    outcomes.append((run, _put(b, occupied, part)))
                    placed = True
                else:
                    left.append(run)
        if not placed:
            outcomes += [(run, "rests on no column or beam") for run in left]
            break
        pending = left
    _label_pieces(b, outcomes)


def _along(part: Part, axis: int) -> bool:
    """Whether ``part`` is a beam lying along ``axis`` (more than one cell long)."""
    return kind_named(part.kind).shape == HORIZONTAL_BAR and part.lo[axis] != part.hi[axis]


def _cut(b: Building, piece: _Piece, occupied: dict[Cell, int]) -> list[_Piece] | str:
    """The runs of ``piece`` between the cells already taken (by columns and by beams across
    it), or why it is left out: it overlaps a beam lying along the same line."""
    for a in piece.cells:
        j = occupied.get(piece.at(a))
        if j is not None and _along(b.parts[j], piece.axis):
            other = b.parts[j].element
            return f"overlaps {other.ifc_type} {other.global_id} {other.name!r} at the cell size"
    runs = _runs_between(piece.cells, lambda a: piece.at(a) in occupied)
    return [_Piece(piece.element, piece.axis, piece.across, piece.z, run) for run in runs]


def _runs_between(cells: list[int], cut) -> list[list[int]]:
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


def _beam_supports(b: Building, before: dict[Cell, int], run: _Piece) -> tuple[int, ...]:
    """The parts in ``before`` that ``run`` rests on: of a kind its kind rests on (the kind
    table) and not above it; a column sharing a face with it, a beam under it or at one of
    its ends (a beam lying alongside carries nothing)."""
    rests_on = ifc_kind(run.element.ifc_type, HORIZONTAL_BAR).rests_on
    found: set[int] = set()
    for a in run.cells:
        x, y, z = run.at(a)
        for face in _FACES:
            j = before.get((x + face[0], y + face[1], z + face[2]))
            if j is None or j in found:
                continue
            other = kind_named(b.parts[j].kind)
            alongside = other.shape == HORIZONTAL_BAR and face[2] == 0 and face[run.axis] == 0
            low = min(b.parts[j].lo[2], b.parts[j].hi[2]) <= z
            if other.code in rests_on and low and not alongside:
                found.add(j)
    return tuple(sorted(found))


def _label_pieces(b: Building, outcomes: list[tuple[_Piece, int | str]]) -> None:
    """Number the pieces of every split beam ("part 2 of 3", along its axis) and report the
    pieces left out."""
    by_element: dict[int, list[tuple[_Piece, int | str]]] = {}
    for run, result in outcomes:
        by_element.setdefault(id(run.element), []).append((run, result))
    for pieces in by_element.values():
        pieces.sort(key=lambda o: o[0].cells[0])
        for k, (run, result) in enumerate(pieces, 1):
            piece = f"part {k} of {len(pieces)}" if len(pieces) > 1 else ""
            if isinstance(result, int):
                b.parts[result] = replace(b.parts[result], piece=piece)
            else:
                b.skipped.append(_skip(run.element, f"{piece + ': ' if piece else ''}{result}"))


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
