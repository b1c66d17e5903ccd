"""The supports rules of the kind table: what each target rests on, checked or derived at load.

Each kind has one rule (``multicrane.core.kinds``; ``rests_on``: the kinds it may rest on):

- **stacked** (a column): at the ground (``z = 1``) on a foundation, above it on a target of a
  ``rests_on`` kind directly under its bottom cell; the support is implied, never named;
- **named** (a beam, on columns or on other beams): the file names its supports, at least
  one, each a ``rests_on`` target other than itself that touches it and does not lie above
  it (``check_stated``, run with the other whole-scenario checks; a cycle of beams on beams
  is refused by the solvability check);
- **under some** (a slab): it rests on the ``rests_on`` targets directly under its cells, at
  least one;
- **under all** (a wall): on the ground only on a foundation strip (a foundation under every
  cell of its bottom row); above the ground every cell under its bottom row must belong to a
  ``rests_on`` target, and those targets are its supports.

The "under" rules derive the supports where the file names none (``derive_supports``, once the
targets are known not to overlap); a file may also name them, and each must then be of a kind
it may rest on and lie directly under it. Everything here is pure Python over a handful of
cells, run at load time.
"""

from __future__ import annotations

from dataclasses import replace

from multicrane.core.kinds import NAMED, STACKED, UNDER_ALL, UNDER_SOME, kind_spec, rests_on_names
from multicrane.core.schema import Cell, Pose, Scenario
from multicrane.scenario.toml_table import TomlTable
from multicrane.sim import geometry


def check_stated(s: Scenario, tables: list[TomlTable], target_cells: dict[Cell, int]) -> None:
    """The stacked and named rules (``target_cells``: the target holding each target cell)."""
    foundations = set(s.foundations)
    for i, c in enumerate(s.components):
        spec = kind_spec(c.kind)
        t = tables[i]
        cells = geometry.pose_cells(*c.target)
        if spec.supports == STACKED:
            x, y, z = min(cells, key=lambda cell: cell[2])
            below = target_cells.get((x, y, z - 1))
            on_support = below is not None and s.components[below].kind in spec.rests_on
            if z == 1 and (x, y) not in foundations:
                raise t.refuse(
                    "target", f"{spec.name} target at ({x}, {y}) has no foundation there"
                )
            if z > 1 and not on_support:
                rests_on = rests_on_names(spec)
                raise t.refuse(
                    "target", f"{spec.name} target floats: no {rests_on} target directly below it"
                )
        elif spec.supports == NAMED:
            if not c.supports:
                raise t.refuse(
                    "supports", f"a {spec.name} target needs the {rests_on_names(spec)} targets "
                    "it rests on"
                )
            for j in c.supports:
                other = s.components[j]
                if j == i:
                    raise t.refuse(
                        "supports", f"{other.id!r} is this {spec.name} itself, not a "
                        f"{rests_on_names(spec)} it rests on"
                    )
                if other.kind not in spec.rests_on:
                    raise t.refuse("supports", f"{other.id!r} is not a {rests_on_names(spec)}")
                under = geometry.pose_cells(*other.target)
                if not geometry.touches(cells, under):
                    raise t.refuse(
                        "supports", f"the target of {other.id!r} does not touch this {spec.name}"
                    )
                if min(z for *_, z in under) > min(z for *_, z in cells):
                    raise t.refuse(
                        "supports", f"the target of {other.id!r} lies above this {spec.name}: "
                        "it rests on what is under or beside it"
                    )


def derive_supports(s: Scenario, tables: list[TomlTable]) -> Scenario:
    """The scenario with the supports of every component of an "under" rule filled in
    (derived where the file names none) and checked; one with no support is a ScenarioError
    naming it."""
    owner: dict[Cell, int] = {}
    for j, c in enumerate(s.components):
        for cell in geometry.pose_cells(*c.target):
            owner[cell] = j
    foundations = set(s.foundations)
    comps = list(s.components)
    for i, c in enumerate(s.components):
        spec = kind_spec(c.kind)
        if spec.supports not in (UNDER_SOME, UNDER_ALL):
            continue
        t = tables[i]
        below = _cells_below(c.target)
        kinds = rests_on_names(spec)
        under = {
            owner[b] for b in below if b in owner and s.components[owner[b]].kind in spec.rests_on
        }
        if spec.supports == UNDER_ALL:
            on_ground = below[0][2] == 0
            if on_ground:
                bare = [list(b) for b in below if (b[0], b[1]) not in foundations]
            else:
                bare = [list(b) for b in below if b not in owner or owner[b] not in under]
            if bare:
                what = "foundation" if on_ground else f"{kinds} target"
                raise t.fail(
                    "target", t.data["target"], f"{spec.name} {c.id!r} has no support: no {what} "
                    f"under cell(s) {bare} below its bottom row"
                )
        elif not under:
            raise t.fail(
                "target", t.data["target"],
                f"{spec.name} {c.id!r} has no support: no {kinds} target directly under it",
            )
        if c.supports:
            for j in c.supports:
                if j not in under:
                    raise t.fail(
                        "supports", t.data.get("supports"),
                        f"{s.components[j].id!r} is not a {kinds} target directly under "
                        f"{spec.name} {c.id!r}",
                    )
        else:
            comps[i] = replace(c, supports=tuple(sorted(under)))
    return replace(s, components=tuple(comps))


def _cells_below(target: Pose) -> list[Cell]:
    """The cells under a target's bottom row (under every cell of a horizontal one)."""
    cells = geometry.pose_cells(*target)
    bottom = min(z for _, _, z in cells)
    return [(x, y, z - 1) for x, y, z in cells if z == bottom]
