"""Checks that need the whole scenario: overlaps, foundations, supports, pick-up poses, starts.

Run by the loader once every key has been read; a failure names the component's key in the
file (through the component's :class:`~multicrane.scenario.toml_table.TomlTable`).
"""

from __future__ import annotations

from multicrane.core.codes import PANELS, Kind
from multicrane.core.schema import Cell, Scenario, ScenarioError
from multicrane.scenario.toml_table import TomlTable
from multicrane.sim import geometry
from multicrane.sim.reach import uncarriable
from multicrane.sim.start import has_candidates


def check_scenario(s: Scenario, tables: list[TomlTable]) -> None:
    """Checks that need the whole scenario: overlaps, foundations, supports, pick-up poses."""
    src = s.source
    obstacle = s.obstacle_cells()
    foundations = set(s.foundations)

    def fail(i: int, key: str, problem: str) -> ScenarioError:
        t = tables[i]
        return t.fail(key, t.data.get(key), problem)

    # Targets: in the construction area, clear of obstacles and of each other.
    target_cells: dict[Cell, int] = {}
    for i, c in enumerate(s.components):
        for cell in geometry.pose_cells(*c.target):
            if not s.in_construction_area(cell[0], cell[1]):
                raise fail(i, "target", f"cell {list(cell)} lies outside the construction area")
            if cell in obstacle:
                raise fail(i, "target", f"cell {list(cell)} is inside an obstacle")
            if cell in target_cells:
                other = s.components[target_cells[cell]].id
                raise fail(i, "target", f"overlaps the target of component {other!r}")
            target_cells[cell] = i

    # Columns stand on a foundation or on another column target; beams rest on their supports
    # (panels: multicrane.scenario.panels, once the targets are known not to overlap).
    for i, c in enumerate(s.components):
        cells = geometry.pose_cells(*c.target)
        if c.kind is Kind.COLUMN:
            bottom = min(cells, key=lambda cell: cell[2])
            x, y, z = bottom
            below = target_cells.get((x, y, z - 1))
            on_column = below is not None and s.components[below].kind is Kind.COLUMN
            if z == 1 and (x, y) not in foundations:
                raise fail(i, "target", f"column target at ({x}, {y}) has no foundation there")
            if z > 1 and not on_column:
                raise fail(i, "target", "column target floats: no column target directly below it")
        elif c.kind is Kind.BEAM:
            if not c.supports:
                raise fail(i, "supports", "a beam target needs the column targets it rests on")
            for j in c.supports:
                if s.components[j].kind is not Kind.COLUMN:
                    raise fail(i, "supports", f"{s.components[j].id!r} is not a column")
                if not geometry.touches(cells, geometry.pose_cells(*s.components[j].target)):
                    raise fail(
                        i,
                        "supports",
                        f"the target of {s.components[j].id!r} does not touch this beam",
                    )

    # Pre-built placements: compatible targets.
    for i, c in enumerate(s.components):
        for j in c.prebuilt_on:
            other = s.components[j]
            if (other.kind, other.length) != (c.kind, c.length) or (
                c.kind in PANELS and geometry.shape_key(c.kind, c.target)
                != geometry.shape_key(other.kind, other.target)
            ):
                raise fail(i, "prebuilt_on", f"target of {other.id!r} has another kind or length")
    if sum(c.prebuilt for c in s.components) == len(s.components):
        raise ScenarioError(f"{src}: components: every component is pre-built; nothing to do")

    # Fixed initial poses: inside the yard, clear of obstacles, targets and each other;
    # and their pick-up poses must be free of obstacles and inside the site.
    taken: dict[Cell, int] = {}
    for i, c in enumerate(s.components):
        if c.initial is None:
            continue
        for cell in geometry.pose_cells(*c.initial):
            if s.in_construction_area(cell[0], cell[1]):
                raise fail(
                    i, "initial", f"cell {list(cell)} lies in the construction area, not the yard"
                )
            if cell in obstacle:
                raise fail(i, "initial", f"cell {list(cell)} is inside an obstacle")
            if cell in taken:
                raise fail(i, "initial", f"overlaps component {s.components[taken[cell]].id!r}")
            taken[cell] = i
    for i, c in enumerate(s.components):
        if c.initial is None:
            continue
        lifted = geometry.pickup_pose(c, s.beam_lift_z)
        for cell in geometry.pose_cells(*lifted):
            if not (
                0 <= cell[0] < s.size[0] and 0 <= cell[1] < s.size[1] and 1 <= cell[2] <= s.size[2]
            ):
                raise fail(i, "initial", f"its pick-up pose {lifted} leaves the site")
            if cell in obstacle:
                raise fail(i, "initial", f"its pick-up pose {lifted} is blocked by an obstacle")

    # Random starts: every component drawn at reset must have at least one possible pose.
    if s.random_start is not None:
        for i, c in enumerate(s.components):
            if c.initial is None and not c.prebuilt and not has_candidates(s, c):
                raise fail(i, "id", "the random start rule has no valid pose for this component")


def check_reach(s: Scenario, tables: list[TomlTable]) -> None:
    """With ``[[crane]]`` entries: every component can be carried from every start it can have
    to a compatible target by one crane inside its zone (``multicrane.sim.reach``)."""
    found = uncarriable(s)
    if found is not None:
        i, _, problem = found
        t = tables[i]
        raise ScenarioError(f"{s.source}: {t.path} (id {s.components[i].id!r}): {problem}")
