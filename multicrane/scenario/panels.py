"""Panels in scenario files: the shape rules of slabs and walls, and the supports they rest on.

A panel (``Kind.SLAB``, ``Kind.WALL``) is given by two opposite corner cells of a rectangle
one cell thick: a slab is horizontal (``z0 == z1``), a wall vertical (``x0 == x1`` or
``y0 == y1``, spanning z). Both span at least two cells along each of their two axes (a
thinner one is a beam or a column). In the yard a panel lies flat (``z0 == z1``) with the
same two side lengths as its target, in either orientation; its pick-up pose is
``geometry.lifted_pose``.

Supports (the precedence the loader derives, ``derive_supports``):

- a **slab** rests on the beam and wall targets directly under its cells (at least one);
- a **wall** stands on the ground only on a foundation strip (a foundation under every cell
  of its bottom row); above the ground every cell under its bottom row must belong to a slab
  or beam target, and those targets are its supports.

A panel may also name its ``supports``; each must then be of a kind it may rest on and lie
directly under it. Everything here is pure Python over a handful of cells, run at load time.
"""

from __future__ import annotations

from dataclasses import replace

from multicrane.core.codes import Kind
from multicrane.core.schema import Cell, Pose, Scenario
from multicrane.scenario.toml_table import TomlTable
from multicrane.sim import geometry

# What each panel kind may rest on.
RESTS_ON = {Kind.SLAB: (Kind.BEAM, Kind.WALL), Kind.WALL: (Kind.SLAB, Kind.BEAM)}


def target_problem(kind: Kind, target: Pose) -> str | None:
    """Why a panel target is malformed, or None."""
    size = geometry.extent(*target)
    if kind is Kind.SLAB:
        if size[2] != 1:
            return "a slab target must be horizontal (z0 == z1)"
        if min(size[0], size[1]) < 2:
            return "a slab spans at least 2 cells along x and along y (a thinner one is a beam)"
        return None
    if size[2] < 2 or 1 not in size[:2]:
        return "a wall target must be upright: x0 == x1 or y0 == y1, spanning at least 2 in z"
    if max(size[0], size[1]) < 2:
        return "a wall spans at least 2 cells along x or y (a thinner one is a column)"
    return None


def initial_problem(kind: Kind, initial: Pose, target: Pose) -> str | None:
    """Why a panel's yard pose does not fit its target, or None."""
    size, goal = geometry.extent(*initial), geometry.extent(*target)
    if size[2] != 1:
        return "a panel lies flat in the yard (z0 == z1)"
    sides = sorted(n for n in goal if n > 1) if kind is Kind.WALL else sorted(goal[:2])
    if sorted(size[:2]) != sides:
        return f"spans {size[0]} x {size[1]} cells; its target's sides are {sides[0]} x {sides[1]}"
    return None


def derive_supports(s: Scenario, tables: list[TomlTable]) -> Scenario:
    """The scenario with every panel's supports filled in (derived where the file names
    none) and checked; a panel with no support is a ScenarioError naming it."""
    owner: dict[Cell, int] = {}
    for j, c in enumerate(s.components):
        for cell in geometry.pose_cells(*c.target):
            owner[cell] = j
    foundations = set(s.foundations)
    comps = list(s.components)
    for i, c in enumerate(s.components):
        if c.kind not in RESTS_ON:
            continue
        t = tables[i]
        below = _cells_below(c.kind, c.target)
        allowed = RESTS_ON[c.kind]
        kinds = " or ".join(k.name.lower() for k in allowed)
        under = {owner[b] for b in below if b in owner and s.components[owner[b]].kind in allowed}
        if c.kind is Kind.WALL:
            on_ground = below[0][2] == 0
            if on_ground:
                bare = [list(b) for b in below if (b[0], b[1]) not in foundations]
            else:
                bare = [list(b) for b in below if b not in owner or owner[b] not in under]
            if bare:
                what = "foundation" if on_ground else f"{kinds} target"
                raise t.fail(
                    "target", t.data["target"], f"wall {c.id!r} has no support: no {what} under "
                    f"cell(s) {bare} below its bottom row"
                )
        elif not under:
            raise t.fail(
                "target", t.data["target"],
                f"slab {c.id!r} has no support: no {kinds} target directly under it",
            )
        if c.supports:
            for j in c.supports:
                if j not in under:
                    raise t.fail(
                        "supports", t.data.get("supports"),
                        f"{s.components[j].id!r} is not a {kinds} target directly under "
                        f"{c.kind.name.lower()} {c.id!r}",
                    )
        else:
            comps[i] = replace(c, supports=tuple(sorted(under)))
    return replace(s, components=tuple(comps))


def _cells_below(kind: Kind, target: Pose) -> list[Cell]:
    """The cells a panel rests on: under every cell of a slab, under a wall's bottom row."""
    cells = geometry.pose_cells(*target)
    bottom = min(z for _, _, z in cells)
    return [(x, y, z - 1) for x, y, z in cells if kind is Kind.SLAB or z == bottom]
