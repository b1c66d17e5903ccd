"""The scenario loader: a TOML file (by shipped name or path) read strictly into a Scenario.

Loading runs no code (``tomllib``). Every problem is reported as a
:class:`~multicrane.core.schema.ScenarioError` whose message names the file, the key and the
value; the format is documented in ``scenarios/README.md``.
"""

from __future__ import annotations

import hashlib
import math
import tomllib
from pathlib import Path

from multicrane.core.schema import (
    Band,
    Box,
    CraneSpec,
    RandomStart,
    RewardSpec,
    Scenario,
    ScenarioError,
)
from multicrane.scenario import limits
from multicrane.scenario.catalog import resolve
from multicrane.scenario.checks import check_reach, check_scenario
from multicrane.scenario.components_table import in_site, outside, read_component, read_ids
from multicrane.scenario.events_table import parse_events
from multicrane.scenario.solvable import check_solvable
from multicrane.scenario.supports import derive_supports
from multicrane.scenario.toml_table import TomlTable

FORMAT_VERSION = 1


def load_scenario(scenario: str | Path | Scenario) -> Scenario:
    """Load and validate a scenario by shipped name or path (a Scenario passes through)."""
    if isinstance(scenario, Scenario):
        return scenario
    path = resolve(scenario)
    raw = path.read_bytes()
    return parse_scenario(raw, source=str(path), default_name=path.stem)


def parse_scenario(raw: bytes | str, source: str = "<string>", default_name: str = "") -> Scenario:
    """Validate scenario text; ``source`` is the name used in error messages."""
    try:
        data_bytes = raw.encode("utf-8") if isinstance(raw, str) else raw
        data = limits.parse_toml(data_bytes, source)  # size and nesting bounded
    except UnicodeError as exc:
        raise ScenarioError(f"{source}: not UTF-8 text ({exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{source}: not valid TOML: {exc}") from None
    limits.check_component_count(source, data)
    builder = _Builder(source, data, hashlib.sha256(data_bytes).hexdigest(), default_name)
    scenario = builder.build()
    limits.check_numbers(scenario)
    check_solvable(scenario)
    return scenario


_DIRECTIONS = {
    "+x": (1, 0, 0),
    "-x": (-1, 0, 0),
    "+y": (0, 1, 0),
    "-y": (0, -1, 0),
}


class _Builder:
    """Turns the parsed TOML into a validated Scenario, one section at a time."""

    def __init__(self, source: str, data: dict, sha256: str, default_name: str):
        self.source = source
        self.top = TomlTable(source, "", data)
        self.sha256 = sha256
        self.default_name = default_name

    def build(self) -> Scenario:
        top = self.top
        fmt = top.get("format", int)
        if fmt != FORMAT_VERSION:
            raise top.fail(
                "format", fmt, f"unsupported format (this library reads {FORMAT_VERSION})"
            )
        name = top.get("name", str, self.default_name)
        description = top.get("description", str, "")

        site = top.table("site")
        size = self._size(site)
        self.size = size
        area = self._area(site)
        foundations = self._foundations(site)
        obstacles = self._obstacles(site)
        site.finish()

        rules = top.table("rules")
        reward = self._reward(top.table("reward", required=False))
        random_start = self._random_start(top.table("random_start", required=False))
        comp_tables = top.tables("components")
        crane_specs = self._crane_specs(top)
        events = top.table("events", required=False)
        top.finish()
        if not comp_tables:
            raise ScenarioError(
                f"{self.source}: components: a scenario needs at least one component"
            )

        ids = read_ids(comp_tables)
        interchangeable = rules.get("interchangeable_targets", bool, False)
        components = [
            read_component(t, ids, size, random_start is not None, interchangeable)
            for t in comp_tables
        ]
        order = self._order(rules, ids)
        event_spec = None if events is None else parse_events(events, size, ids)
        cranes, step_limit, assembly_steps, beam_lift_z = self._rules(rules, len(crane_specs))
        scenario = Scenario(
            name=name,
            description=description,
            source=self.source,
            sha256=self.sha256,
            size=size,
            construction_area=area,
            foundations=foundations,
            obstacles=obstacles,
            components=tuple(components),
            order=order,
            cranes=cranes,
            step_limit=step_limit,
            interchangeable_targets=interchangeable,
            assembly_steps=assembly_steps,
            beam_lift_z=beam_lift_z,
            reward=reward,
            random_start=random_start,
            crane_specs=crane_specs,
            events=event_spec,
        )
        check_scenario(scenario, comp_tables)
        scenario = derive_supports(scenario, comp_tables)
        check_reach(scenario, comp_tables)
        return scenario

    def _rules(self, rules: TomlTable, n_crane_specs: int) -> tuple[int, int, int, int | None]:
        """The crane count, step limit, assembly steps and beam lift height of ``[rules]``."""
        cranes = rules.get("cranes", int, n_crane_specs or 1)
        if cranes < 1:
            raise rules.fail("cranes", cranes, "must be at least 1")
        if n_crane_specs and cranes != n_crane_specs:
            raise rules.fail(
                "cranes",
                cranes,
                f"differs from the {n_crane_specs} [[crane]] entries (give the same count, "
                "or leave rules.cranes out)",
            )
        step_limit = rules.get("step_limit", int)
        if step_limit < 1:
            raise rules.fail("step_limit", step_limit, "must be at least 1")
        assembly_steps = rules.get("assembly_steps", int, 1)
        if assembly_steps < 1:
            raise rules.fail("assembly_steps", assembly_steps, "must be at least 1")
        beam_lift_z = rules.get("beam_lift_z", int, None)
        if beam_lift_z is not None and not 1 <= beam_lift_z <= self.size[2]:
            raise rules.fail("beam_lift_z", beam_lift_z, f"must lie in 1..{self.size[2]}")
        rules.finish()
        return cranes, step_limit, assembly_steps, beam_lift_z

    # -- site ------------------------------------------------------------------------------

    def _size(self, site: TomlTable) -> tuple[int, int, int]:
        size = site.ints("size", 3)
        if any(v < 1 for v in size) or size[0] > 256 or size[1] > 256 or size[2] > 64:
            raise site.fail("size", list(size), "must be 1..256 cells along x and y, height 1..64")
        limits.check_site_volume(site, size)
        return size  # type: ignore[return-value]

    def _area(self, site: TomlTable) -> tuple[int, int, int, int]:
        box = site.table("construction_area")
        lo = box.ints("min", 2)
        hi = box.ints("max", 2)
        box.finish()
        for name, corner in (("min", lo), ("max", hi)):
            if not self._in_plan(corner):
                raise box.fail(name, list(corner), "lies outside the site")
        if lo[0] > hi[0] or lo[1] > hi[1]:
            raise box.fail("max", list(hi), f"must not be below min {list(lo)}")
        return (lo[0], lo[1], hi[0], hi[1])

    def _foundations(self, site: TomlTable) -> tuple[tuple[int, int], ...]:
        raw = site.get("foundations", list, [])
        out: list[tuple[int, int]] = []
        for i, item in enumerate(raw):
            xy = site.check_ints(f"foundations[{i}]", item, 2)
            if not self._in_plan(xy):
                raise site.fail(f"foundations[{i}]", item, "lies outside the site")
            if xy in out:
                raise site.fail(f"foundations[{i}]", item, "duplicate foundation")
            out.append(xy)  # type: ignore[arg-type]
        return tuple(out)

    def _obstacles(self, site: TomlTable) -> tuple[Box, ...]:
        boxes: list[Box] = []
        for t in site.tables("obstacles") if site.has("obstacles") else []:
            lo = t.ints("min", 3)
            hi = t.ints("max", 3)
            t.finish()
            for name, corner in (("min", lo), ("max", hi)):
                if not in_site(corner, self.size):
                    raise t.fail(name, list(corner), outside(self.size))
            if any(a > b for a, b in zip(lo, hi, strict=True)):
                raise t.fail("max", list(hi), f"must not be below min {list(lo)}")
            box = Box(lo, hi)  # type: ignore[arg-type]
            cells = set(box.cells())
            for j, other in enumerate(boxes):
                if cells & set(other.cells()):
                    raise t.fail("min", list(lo), f"this obstacle overlaps obstacle [{j}]")
            boxes.append(box)
        return tuple(boxes)

    def _in_plan(self, xy: tuple[int, ...]) -> bool:
        return 0 <= xy[0] < self.size[0] and 0 <= xy[1] < self.size[1]

    # -- crane reach -----------------------------------------------------------------------

    def _crane_specs(self, top: TomlTable) -> tuple[CraneSpec, ...]:
        """The optional ``[[crane]]`` array: one tower crane (base column, plan radius) each."""
        if not top.has("crane"):
            return ()
        tables = top.tables("crane")
        if not tables:
            raise top.fail("crane", [], "needs at least one [[crane]] entry when given")
        specs = []
        for t in tables:
            base = t.ints("base", 2)
            if not self._in_plan(base):
                x, y, _ = self.size
                where = f"x 0..{x - 1}, y 0..{y - 1}"
                raise t.fail("base", list(base), f"lies outside the site ({where})")
            radius = t.get("radius", float)
            if not math.isfinite(radius) or radius <= 0:
                raise t.fail("radius", radius, "must be a finite number of cells above 0")
            t.finish()
            specs.append(CraneSpec(base=base, radius=radius))  # type: ignore[arg-type]
        return tuple(specs)

    # -- reward and random start -------------------------------------------------------------

    def _reward(self, t: TomlTable | None) -> RewardSpec:
        if t is None:
            return RewardSpec()
        spec = RewardSpec(
            completion=t.get("completion", float, RewardSpec.completion),
            move_limit=t.get("move_limit", int, RewardSpec.move_limit),
            over_limit_cost=t.get("over_limit_cost", float, RewardSpec.over_limit_cost),
            step_cost=t.get("step_cost", float, RewardSpec.step_cost),
        )
        t.finish()
        if spec.move_limit < 0:
            raise t.fail("move_limit", spec.move_limit, "must not be negative")
        return spec

    def _random_start(self, t: TomlTable | None) -> RandomStart | None:
        if t is None:
            return None
        z = t.get("z", int, 1)
        if not 1 <= z <= self.size[2]:
            raise t.fail("z", z, f"must lie in 1..{self.size[2]}")
        bands: list[Band] = []
        for b in t.tables("bands"):
            bx = b.ints("x", 2)
            by = b.ints("y", 2)
            b.finish()
            for name, rng, n in (("x", bx, self.size[0]), ("y", by, self.size[1])):
                if not 0 <= rng[0] <= rng[1] < n:
                    raise b.fail(name, list(rng), f"must be an increasing range inside 0..{n - 1}")
            for j, other in enumerate(bands):
                if max(bx[0], other.x[0]) <= min(bx[1], other.x[1]):
                    raise b.fail("x", list(bx), f"overlaps the x range of band [{j}]")
            bands.append(Band(bx, by))  # type: ignore[arg-type]
        if not bands:
            raise t.fail("bands", [], "needs at least one band")
        names = t.get("directions", list, ["-x", "-y"])
        if not names:
            raise t.fail("directions", names, "needs at least one direction")
        for name in names:
            if not isinstance(name, str) or name not in _DIRECTIONS:
                raise t.fail("directions", names, f"{name!r} is not one of {sorted(_DIRECTIONS)}")
        t.finish()
        return RandomStart(z, tuple(bands), tuple(_DIRECTIONS[n] for n in names))

    # -- list order ------------------------------------------------------------------------

    def _order(self, rules: TomlTable, ids: list[str]) -> tuple[int, ...]:
        raw = rules.get("order", list, list(ids))
        order: list[int] = []
        for ref in raw:
            ref_id = str(ref) if isinstance(ref, (str, int)) and not isinstance(ref, bool) else None
            if ref_id is None or ref_id not in ids:
                raise rules.fail("order", raw, f"{ref!r} is not a component id of this scenario")
            if ids.index(ref_id) in order:
                raise rules.fail("order", raw, f"{ref!r} is listed twice")
            order.append(ids.index(ref_id))
        missing = [i for i in ids if ids.index(i) not in order]
        if missing:
            raise rules.fail("order", raw, f"does not list component(s) {missing}")
        return tuple(order)
