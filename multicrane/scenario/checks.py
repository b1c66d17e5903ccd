"""Checks that need the whole scenario: overlaps, foundations, supports, pick-up poses, starts.

Run by the loader once every key has been read; a failure names the component's key in the
file (through the component's :class:`~multicrane.scenario.toml_table.TomlTable`).
"""

from __future__ import annotations

from multicrane.core.kinds import kind_spec
from multicrane.core.schema import Cell, Scenario, ScenarioError
from multicrane.scenario.components_table import in_site
from multicrane.scenario.supports import check_stated
from multicrane.scenario.toml_table import TomlTable
from multicrane.sim import geometry
from multicrane.sim.reach import uncarriable
from multicrane.sim.start import has_candidates


def check_scenario(s: Scenario, tables: list[TomlTable]) -> None:
    """Checks that need the whole scenario: overlaps, foundations, supports, pick-up poses."""
    target_cells = _check_targets(s, tables)
    # Stacked and named supports (the "under" rules: multicrane.scenario.supports, once the
    # targets are known not to overlap).
    check_stated(s, tables, target_cells)
    _check_prebuilt(s, tables)
    _check_initials(s, tables)
    # Random starts: every component drawn at reset must have at least one possible pose.
    if s.random_start is not None:
        for i, c in enumerate(s.components):
            if c.initial is None and not c.prebuilt and not has_candidates(s, c):
                raise tables[i].refuse(
                    "id", "the random start rule has no valid pose for this component"
                )


def _check_targets(s: Scenario, tables: list[TomlTable]) -> dict[Cell, int]:
    """Targets: in the construction area, clear of obstacles and of each other. Returns the
    target holding each target cell."""
    obstacle = s.obstacle_cells()
    target_cells: dict[Cell, int] = {}
    for i, c in enumerate(s.components):
        t = tables[i]
        for cell in geometry.pose_cells(*c.target):
            if not s.in_construction_area(cell[0], cell[1]):
                raise t.refuse("target", f"cell {list(cell)} lies outside the construction area")
            if cell in obstacle:
                raise t.refuse("target", f"cell {list(cell)} is inside an obstacle")
            if cell in target_cells:
                other = s.components[target_cells[cell]].id
                raise t.refuse("target", f"overlaps the target of component {other!r}")
            target_cells[cell] = i
    return target_cells


def _check_prebuilt(s: Scenario, tables: list[TomlTable]) -> None:
    """Pre-built placements: compatible targets; and something left to build."""
    for i, c in enumerate(s.components):
        for j in c.prebuilt_on:
            other = s.components[j]
            if (other.kind, other.length) != (c.kind, c.length) or (
                kind_spec(c.kind).panel
                and geometry.shape_key(c.kind, c.target)
                != geometry.shape_key(other.kind, other.target)
            ):
                raise tables[i].refuse(
                    "prebuilt_on", f"target of {other.id!r} has another kind or length"
                )
    if sum(c.prebuilt for c in s.components) == len(s.components):
        raise ScenarioError(f"{s.source}: components: every component is pre-built; nothing to do")


def _check_initials(s: Scenario, tables: list[TomlTable]) -> None:
    """Fixed initial poses: inside the yard, clear of obstacles, targets and each other; and
    their pick-up poses must be free of obstacles and inside the site."""
    obstacle = s.obstacle_cells()
    taken: dict[Cell, int] = {}
    for i, c in enumerate(s.components):
        if c.initial is None:
            continue
        t = tables[i]
        for cell in geometry.pose_cells(*c.initial):
            if s.in_construction_area(cell[0], cell[1]):
                raise t.refuse(
                    "initial", f"cell {list(cell)} lies in the construction area, not the yard"
                )
            if cell in obstacle:
                raise t.refuse("initial", f"cell {list(cell)} is inside an obstacle")
            if cell in taken:
                raise t.refuse("initial", f"overlaps component {s.components[taken[cell]].id!r}")
            taken[cell] = i
    for i, c in enumerate(s.components):
        if c.initial is None:
            continue
        lifted = geometry.pickup_pose(c, s.beam_lift_z)
        for cell in geometry.pose_cells(*lifted):
            if not in_site(cell, s.size):
                raise tables[i].refuse("initial", f"its pick-up pose {lifted} leaves the site")
            if cell in obstacle:
                raise tables[i].refuse(
                    "initial", f"its pick-up pose {lifted} is blocked by an obstacle"
                )


def check_reach(s: Scenario, tables: list[TomlTable]) -> None:
    """With ``[[crane]]`` entries: every component can be carried from every start it can have
    to a compatible target by one crane inside its zone (``multicrane.sim.reach``)."""
    found = uncarriable(s)
    if found is not None:
        i, _, problem = found
        t = tables[i]
        raise ScenarioError(f"{s.source}: {t.path} (id {s.components[i].id!r}): {problem}")
