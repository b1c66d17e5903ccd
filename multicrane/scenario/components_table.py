"""The ``[[components]]`` tables: each read strictly into a ComponentSpec, its poses checked
against its kind's shape (``multicrane.core.kinds``).

A pose is two cells inside the site. A bar (column, beam) is given by its two end cells, on
one axis-parallel line (``length`` cells long where the file gives a length): a vertical bar's
target stands upright (along z), a horizontal bar's lies horizontally. A panel (slab, wall) is
given by two opposite corner cells of a rectangle one cell thick and has no ``length``: a
horizontal panel's target is horizontal (``z0 == z1``) and spans at least 2 cells along x and
along y; a vertical panel's is upright (``x0 == x1`` or ``y0 == y1``) and spans at least 2
cells along z and along x or y. In the yard a panel lies flat (``z0 == z1``) with the same two
side lengths as its target, in either orientation; a panel has no random start.
"""

from __future__ import annotations

from multicrane.core.kinds import (
    HORIZONTAL_BAR,
    HORIZONTAL_PANEL,
    KINDS,
    STACKED,
    VERTICAL_BAR,
    VERTICAL_PANEL,
    KindSpec,
    kind_named,
    kind_names,
)
from multicrane.core.schema import ComponentSpec, Pose
from multicrane.scenario.toml_table import TomlTable
from multicrane.sim import geometry


def in_site(cell: tuple[int, ...], size: tuple[int, int, int]) -> bool:
    """The cell lies inside the site (``z`` from 1 to the height; the ground is not in it)."""
    return 0 <= cell[0] < size[0] and 0 <= cell[1] < size[1] and 1 <= cell[2] <= size[2]


def outside(size: tuple[int, int, int]) -> str:
    x, y, h = size
    return f"lies outside the site (x 0..{x - 1}, y 0..{y - 1}, z 1..{h})"


def read_ids(tables: list[TomlTable]) -> list[str]:
    """The components' ids, in file order: each present, non-empty and new."""
    ids: list[str] = []
    for t in tables:
        cid = t.get("id", (str, int))
        cid = str(cid)
        if not cid:
            raise t.fail("id", cid, "must not be empty")
        if cid in ids:
            raise t.fail("id", cid, "duplicate component id")
        ids.append(cid)
    return ids


def read_component(
    t: TomlTable, ids: list[str], size: tuple[int, int, int], random_start: bool,
    interchangeable: bool,
) -> ComponentSpec:  # fmt: skip
    """One ``[[components]]`` table, read by its kind's entry in the kind table."""
    cid = str(t.get("id", (str, int)))
    kind_name = t.get("kind", str)
    spec = kind_named(kind_name)
    if spec is None:
        raise t.fail("kind", kind_name, f"must be {kind_names()}")
    if spec.panel and t.has("length"):
        raise t.fail("length", t.data["length"], "a panel has no length: its corners say")
    length = t.get("length", int, None)
    if length is not None and length < 1:
        raise t.fail("length", length, "must be at least 1")
    target = _pose(t, "target", length, spec.panel, size)
    if problem := target_problem(spec, target):
        raise t.fail("target", t.data["target"], problem)
    length = len(geometry.pose_cells(*target))
    prebuilt = t.get("prebuilt", bool, False)
    initial: Pose | None = None
    if t.has("initial"):
        if prebuilt:
            raise t.fail("initial", t.data["initial"], "a pre-built component has no initial pose")
        initial = _pose(t, "initial", None if spec.panel else length, spec.panel, size)
        if spec.panel and (problem := initial_problem(spec, initial, target)):
            raise t.fail("initial", t.data["initial"], problem)
    elif not prebuilt and (spec.panel or not random_start):
        why = (
            "a panel has no random start"
            if spec.panel
            else "the scenario has no [random_start] and the component is not pre-built"
        )
        raise t.missing("initial", f"required for component {cid!r} ({why})")
    supports = _refs(t, "supports", ids)
    if spec.supports == STACKED and supports:
        naming = [k.name + "s" for k in KINDS.values() if k.supports != STACKED]
        listed = ", ".join(naming[:-1]) + " and " + naming[-1] if len(naming) > 1 else naming[0]
        raise t.fail("supports", t.data["supports"], f"only {listed} name supports")
    prebuilt_on = _refs(t, "prebuilt_on", ids)
    if prebuilt_on and not prebuilt:
        raise t.fail("prebuilt_on", t.data["prebuilt_on"], "only pre-built components use it")
    if prebuilt_on and not interchangeable:
        raise t.fail(
            "prebuilt_on",
            t.data["prebuilt_on"],
            "needs rules.interchangeable_targets = true (it may stand on another target)",
        )
    t.finish()
    return ComponentSpec(
        id=cid,
        kind=spec.code,
        length=length,
        initial=initial,
        target=target,
        supports=supports,
        prebuilt=prebuilt,
        prebuilt_on=prebuilt_on,
    )


def target_problem(spec: KindSpec, target: Pose) -> str | None:
    """Why a target does not have its kind's shape, or None (a bar's target is straight)."""
    size = geometry.extent(*target)
    length, axis = geometry.pose_length(*target), geometry.axis_of(*target)
    if spec.shape == VERTICAL_BAR and length > 1 and axis != 2:
        return f"a {spec.name} target must stand upright (along z)"
    if spec.shape == HORIZONTAL_BAR and axis == 2 and length > 1:
        return f"a {spec.name} target must lie horizontally"
    if spec.shape == HORIZONTAL_PANEL:
        if size[2] != 1:
            return f"a {spec.name} target must be horizontal (z0 == z1)"
        if min(size[0], size[1]) < 2:
            return (
                f"a {spec.name} spans at least 2 cells along x and along y (a thinner one is a "
                "beam)"
            )
    if spec.shape == VERTICAL_PANEL:
        if size[2] < 2 or 1 not in size[:2]:
            return (
                f"a {spec.name} target must be upright: x0 == x1 or y0 == y1, spanning at least "
                "2 in z"
            )
        if max(size[0], size[1]) < 2:
            return f"a {spec.name} spans at least 2 cells along x or y (a thinner one is a column)"
    return None


def initial_problem(spec: KindSpec, initial: Pose, target: Pose) -> str | None:
    """Why a panel's yard pose does not fit its target, or None."""
    size, goal = geometry.extent(*initial), geometry.extent(*target)
    if size[2] != 1:
        return "a panel lies flat in the yard (z0 == z1)"
    sides = sorted(n for n in goal if n > 1) if spec.upright else sorted(goal[:2])
    if sorted(size[:2]) != sides:
        return f"spans {size[0]} x {size[1]} cells; its target's sides are {sides[0]} x {sides[1]}"
    return None


def _pose(
    t: TomlTable, name: str, length: int | None, panel: bool, size: tuple[int, int, int]
) -> Pose:
    raw = t.get(name, list)
    if len(raw) != 2:
        raise t.fail(name, raw, "must be two cells [[x, y, z], [x, y, z]] (node 1, node 2)")
    a = t.check_ints(name, raw[0], 3)
    b = t.check_ints(name, raw[1], 3)
    for cell in (a, b):
        if not in_site(cell, size):
            raise t.fail(name, raw, f"cell {list(cell)} {outside(size)}")
    if not panel and not geometry.is_straight(a, b):
        raise t.fail(name, raw, "node 1 and node 2 must lie on one axis-parallel line")
    if length is not None and geometry.pose_length(a, b) != length:
        raise t.fail(name, raw, f"spans {geometry.pose_length(a, b)} cells, length is {length}")
    return (a, b)  # type: ignore[return-value]


def _refs(t: TomlTable, name: str, ids: list[str]) -> tuple[int, ...]:
    raw = t.get(name, list, [])
    out: list[int] = []
    for ref in raw:
        ref_id = str(ref) if isinstance(ref, (str, int)) and not isinstance(ref, bool) else None
        if ref_id is None or ref_id not in ids:
            raise t.fail(name, raw, f"{ref!r} is not a component id of this scenario")
        if ids.index(ref_id) in out:
            raise t.fail(name, raw, f"{ref!r} is named twice")
        out.append(ids.index(ref_id))
    return tuple(out)
