"""Panels of an imported model: slabs and walls as components on what lies under them, or obstacles.

``place_panels(b, members, mode, skipped)`` sorts the snapped panel parts of
``multicrane.ifc.snap`` as the import's ``--panels`` mode says:

- ``"components"`` (the default): each panel, lowest first, becomes a panel component. Edge
  slices wholly taken by columns and beams are trimmed off first (a wall drawn from column
  centre to column centre, up to the beam above it, keeps the cells between them). It is
  then skipped with the reason when it is thicker than one cell, narrower than two, overlaps
  a component, or does not rest as its kind's supports rule (``multicrane.core.kinds``, the
  rule the loader's ``multicrane.scenario.supports`` checks) asks: a slab on at least one beam
  or wall target directly under it ("rests on nothing", or "only on column targets"); a wall
  on the ground (the import lays a foundation strip under it) or with a slab or beam target
  under every cell of its bottom row (else "rests on nothing" or "partly supported"). Its
  supports are exactly the targets under it, so the loader accepts them as written.
- ``"obstacles"``: the panel's cells become obstacle boxes (``boxes``), less those of earlier
  panels and those of columns and beams or above one: obstacles are there from the start, and
  every column and beam is lowered into place from above, so a floor slab keeps a shaft over
  each target under it.
- ``"skip"``: every panel is reported as skipped.

``panel_yard`` moves the accepted panels' targets onto the site and lays their starts flat in
a strip beyond the site's high-y edge; ``wall_strips`` gives the foundations under the walls
standing on the ground.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from multicrane.core.kinds import UNDER_ALL, kind_named, rests_on_names
from multicrane.core.schema import Box, Cell
from multicrane.ifc.read import Skipped
from multicrane.ifc.scenario_text import PanelSpec
from multicrane.ifc.snap import Building, Part

_Rest = tuple[tuple[int, ...], str | None]  # supports (part indices), or why there are none


@dataclass
class Panels:
    """What the panels became (``panels`` mode): obstacle boxes or panel components."""

    obstacles: list[Box] = field(default_factory=list)
    obstacle_parts: list[int] = field(default_factory=list)  # parts that became obstacles
    specs: list[tuple[int, Part]] = field(default_factory=list)  # (part index, panel component)


def place_panels(b: Building, members: list[int], mode: str, skipped: list[Skipped]) -> Panels:
    """Each panel part as ``mode`` says (module docstring); a panel component's part in
    ``b.parts`` is replaced by its trimmed self with its supports (part indices)."""
    use = Panels()
    taken = {c: i for i in members for c in b.parts[i].cells()}
    lowest: dict[tuple[int, int], int] = {}  # per (x, y): the height of the lowest member cell
    for x, y, z in taken:
        lowest[x, y] = min(z, lowest.get((x, y), z))
    panels = [i for i, p in enumerate(b.parts) if kind_named(p.kind).panel]
    for i in sorted(panels, key=lambda i: (min(b.parts[i].lo[2], b.parts[i].hi[2]), i)):
        part = b.parts[i]
        e = part.element
        if mode == "skip":
            skipped.append(Skipped(e.ifc_type, e.global_id, e.name, "a panel (--panels skip)"))
        elif mode == "obstacles":
            cells = [(x, y, z) for x, y, z in part.cells()
                     if (x, y, z) not in taken and z < lowest.get((x, y), z + 1)]  # fmt: skip
            taken.update(dict.fromkeys(cells, i))
            use.obstacles += boxes(cells)
            use.obstacle_parts.append(i)
        else:
            part, reason = _as_component(b, part, taken)
            if reason is not None:
                skipped.append(Skipped(e.ifc_type, e.global_id, e.name, reason))
                continue
            b.parts[i] = part
            taken.update(dict.fromkeys(part.cells(), i))
            use.specs.append((i, part))
    return use


def _as_component(b: Building, part: Part, taken: dict[Cell, int]) -> tuple[Part, str | None]:
    """The panel trimmed and with its supports, or why it cannot be a component."""
    size = [h - lo + 1 for lo, h in zip(part.lo, part.hi, strict=True)]
    if min(size) > 1:
        return part, (f"a panel thicker than one cell at the cell size ({size[0]} x {size[1]} "
                      f"x {size[2]})")  # fmt: skip
    part = _trim(part, taken)
    size = [h - lo + 1 for lo, h in zip(part.lo, part.hi, strict=True)]
    if sorted(size)[1] == 1:
        return part, "a panel narrower than two cells at the cell size (use a column or beam)"
    clash = next((taken[c] for c in part.cells() if c in taken), None)
    if clash is not None:
        e = b.parts[clash].element
        return part, f"a panel overlapping {e.ifc_type} {e.global_id} {e.name!r} at the cell size"
    supports, reason = _supports(b, part, taken)
    return replace(part, supports=supports), reason


def _trim(part: Part, taken: dict[Cell, int]) -> Part:
    """``part`` less its edge slices (across its wide sides) whose cells are all taken."""
    lo, hi = list(part.lo), list(part.hi)

    def slice_taken(axis: int, at: int) -> bool:
        box = Box(tuple(at if a == axis else lo[a] for a in range(3)),  # type: ignore[arg-type]
                  tuple(at if a == axis else hi[a] for a in range(3)))  # type: ignore[arg-type]
        return all(c in taken for c in box.cells())

    trimmed = True
    while trimmed:
        trimmed = False
        for axis in (a for a in range(3) if hi[a] > lo[a]):
            if slice_taken(axis, lo[axis]):
                lo[axis] += 1
                trimmed = True
            elif slice_taken(axis, hi[axis]):
                hi[axis] -= 1
                trimmed = True
            if hi[axis] == lo[axis]:
                break
    return replace(part, lo=tuple(lo), hi=tuple(hi))  # type: ignore[arg-type]


def _supports(b: Building, part: Part, taken: dict[Cell, int]) -> _Rest:
    """The parts ``part`` rests on by its kind's supports rule, or why it does not rest."""
    spec = kind_named(part.kind)
    cells = part.cells()
    bottom = min(z for _, _, z in cells)
    owners = [taken.get((x, y, z - 1)) for x, y, z in cells if z == bottom]
    codes = {j: kind_named(b.parts[j].kind).code for j in owners if j is not None}
    under = sorted(j for j, code in codes.items() if code in spec.rests_on)
    kinds = rests_on_names(spec)
    if spec.supports == UNDER_ALL:
        bare = sum(j is None or j not in under for j in owners)
        if bottom == 1:
            return (), None  # on the foundation strip the import lays under it
        if bare == len(owners):
            return (), f"rests on nothing: no {kinds} target under its bottom row"
        if bare:
            return (), (f"partly supported: no {kinds} target under {bare} of the "
                        f"{len(owners)} cells of its bottom row")  # fmt: skip
        return tuple(under), None
    if not under:
        others = sorted({b.parts[j].kind for j in owners if j is not None})
        if others:
            return (), f"rests on no {kinds} (only on {' and '.join(others)} targets)"
        return (), f"rests on nothing: no {kinds} target directly under it"
    return tuple(under), None


def boxes(cells: list[Cell]) -> list[Box]:
    """Disjoint boxes covering ``cells`` exactly (greedy: grow along x, then y, then z)."""
    left = set(cells)
    out: list[Box] = []
    for start in sorted(cells, key=lambda c: (c[2], c[1], c[0])):
        if start not in left:
            continue
        hi = list(start)
        for axis in range(3):
            while True:
                hi[axis] += 1
                box = Box(start, tuple(hi))  # type: ignore[arg-type]
                if not all(c in left for c in box.cells()):
                    hi[axis] -= 1
                    break
        box = Box(start, tuple(hi))  # type: ignore[arg-type]
        left.difference_update(box.cells())
        out.append(box)
    return out


def _move(c: Cell, ox: int, oy: int) -> Cell:
    return (c[0] + ox, c[1] + oy, c[2])


def panel_yard(specs: list[tuple[int, Part]], ids: dict[int, str], ox: int, oy: int,
               size: tuple[int, int, int]) -> tuple[list[PanelSpec], tuple[int, int, int]]:
    """Panels' targets moved onto the site, and their starts: lying flat at ``z = 1`` in a
    strip added beyond the site's high-y edge (rows along x, one free cell between panels, a
    margin of half the longest panel side and one cell around the strip, so that every panel
    turns about its centre to its target's orientation inside it); the site's new size."""
    if not specs:
        return [], size
    sides = [sorted((h - lo + 1 for lo, h in zip(p.lo, p.hi, strict=True)), reverse=True)[:2]
             for _, p in specs]  # fmt: skip
    margin = (max(a for a, _ in sides) + 1) // 2 + 1
    X, Y, H = size
    X = max(X, 2 * margin + max(a for a, _ in sides))
    x, y, row = margin, Y + margin, 0
    out: list[PanelSpec] = []
    for (i, p), (a, w) in zip(specs, sides, strict=True):
        if x + a > X - margin:
            x, y, row = margin, y + row + 1, 0
        initial = ((x, y, 1), (x + a - 1, y + w - 1, 1))
        target = (_move(p.lo, ox, oy), _move(p.hi, ox, oy))
        out.append(PanelSpec(ids[i], p.kind, initial, target, tuple(ids[j] for j in p.supports)))
        x, row = x + a + 1, max(row, w)
    return out, (X, y + row + margin, H)


def wall_strips(panels: list[PanelSpec]) -> list[tuple[int, int]]:
    """The foundation strip under every panel of the "under all" rule (a wall) standing on
    the ground: one foundation under each cell of its bottom row."""
    cells: list[tuple[int, int]] = []
    for p in panels:
        (x0, y0, z0), (x1, y1, z1) = p.target
        if kind_named(p.kind).supports == UNDER_ALL and min(z0, z1) == 1:
            cells += [(x, y) for x in range(min(x0, x1), max(x0, x1) + 1)
                      for y in range(min(y0, y1), max(y0, y1) + 1)]  # fmt: skip
    return cells
