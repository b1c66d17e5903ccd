"""Scenario files: the schema, the strict loader and the list of shipped scenarios.

A scenario is data (TOML, read with ``tomllib``): loading one runs no code. Every problem is
reported as a :class:`ScenarioError` whose message names the file, the key and the value. The
schema is documented in ``scenarios/README.md``.
"""

from __future__ import annotations

import difflib
import hashlib
import tomllib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from multicrane import geometry
from multicrane.types import Kind

FORMAT_VERSION = 1
SCENARIO_SUFFIX = ".toml"

Cell = tuple[int, int, int]
Pose = tuple[Cell, Cell]  # (node 1, node 2): the two end cells of a straight component


class ScenarioError(ValueError):
    """A scenario file that cannot be used; the message names file, key and value."""


@dataclass(frozen=True)
class Box:
    """A solid box of cells, both corners included."""

    lo: Cell
    hi: Cell

    def cells(self) -> list[Cell]:
        return [
            (x, y, z)
            for x in range(self.lo[0], self.hi[0] + 1)
            for y in range(self.lo[1], self.hi[1] + 1)
            for z in range(self.lo[2], self.hi[2] + 1)
        ]


@dataclass(frozen=True)
class Band:
    """Random start: node 1's x lies in ``x``; given x, y is drawn from ``y``."""

    x: tuple[int, int]
    y: tuple[int, int]


@dataclass(frozen=True)
class RandomStart:
    """The random initial placement rule, as data (see ``multicrane.start``)."""

    z: int
    bands: tuple[Band, ...]
    directions: tuple[tuple[int, int, int], ...]  # node 2 = node 1 + (length - 1) * direction


@dataclass(frozen=True)
class RewardSpec:
    """Team reward parameters (see ``multicrane.reward``); defaults are the paper's."""

    completion: float = 10.0
    move_limit: int = 15
    over_limit_cost: float = 2.0
    step_cost: float = 1.0


@dataclass(frozen=True)
class ComponentSpec:
    """One prefabricated component. Its own target has the same index as the component."""

    id: str
    kind: Kind
    length: int
    initial: Pose | None  # None: pre-built, or drawn by the random start rule
    target: Pose
    supports: tuple[int, ...]  # indices of the column targets this target rests on
    prebuilt: bool
    prebuilt_on: tuple[int, ...]  # targets a pre-built component may stand on (drawn at reset)


@dataclass(frozen=True)
class Scenario:
    """A validated scenario. Indices into ``components`` also index the targets."""

    name: str
    description: str
    source: str  # the file it came from
    sha256: str  # hash of the file's bytes, for episode records
    size: tuple[int, int, int]  # cells along x and y, and the height (highest z)
    construction_area: tuple[int, int, int, int]  # x0, y0, x1, y1 (inclusive)
    foundations: tuple[tuple[int, int], ...]
    obstacles: tuple[Box, ...]
    components: tuple[ComponentSpec, ...]
    order: tuple[int, ...]  # component indices in list order
    cranes: int
    step_limit: int
    interchangeable_targets: bool
    assembly_steps: int
    beam_lift_z: int | None  # None: a beam is lifted to the height of its own target
    reward: RewardSpec
    random_start: RandomStart | None

    @property
    def n_components(self) -> int:
        return len(self.components)

    @property
    def ids(self) -> tuple[str, ...]:
        return tuple(c.id for c in self.components)

    def index_of(self, component_id: str) -> int:
        return self.ids.index(component_id)

    def in_construction_area(self, x: int, y: int) -> bool:
        x0, y0, x1, y1 = self.construction_area
        return x0 <= x <= x1 and y0 <= y <= y1

    def obstacle_cells(self) -> set[Cell]:
        return {cell for box in self.obstacles for cell in box.cells()}


# ---------------------------------------------------------------------------------------------
# Shipped scenarios


def scenarios_dir() -> Path:
    """The folder of shipped scenarios: inside the installed package, else the repository's."""
    packaged = resources.files("multicrane") / "scenarios"
    if packaged.is_dir():
        return Path(str(packaged))
    return Path(__file__).resolve().parent.parent / "scenarios"


def scenario_names() -> list[str]:
    """Names of the shipped scenarios, e.g. ``["e1s1", ..., "e4s4", "frame2-..."]``."""
    folder = scenarios_dir()
    return sorted(p.stem for p in folder.glob(f"*{SCENARIO_SUFFIX}"))


def resolve(scenario: str | Path) -> Path:
    """A shipped scenario name (``"e3s2"``, case-insensitive) or a path to a TOML file."""
    text = str(scenario)
    candidate = scenarios_dir() / f"{text.lower()}{SCENARIO_SUFFIX}"
    if "/" not in text and "\\" not in text and not text.endswith(SCENARIO_SUFFIX):
        if candidate.is_file():
            return candidate
        raise ScenarioError(
            f"unknown scenario {text!r}: not a shipped name ({', '.join(scenario_names())}) "
            "and not a path to a .toml file"
        )
    path = Path(text)
    if not path.is_file():
        raise ScenarioError(f"{path}: no such scenario file")
    return path


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
        data = tomllib.loads(data_bytes.decode("utf-8"))
    except UnicodeError as exc:
        raise ScenarioError(f"{source}: not UTF-8 text ({exc})") from None
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{source}: not valid TOML: {exc}") from None
    builder = _Builder(source, data, hashlib.sha256(data_bytes).hexdigest(), default_name)
    return builder.build()


# ---------------------------------------------------------------------------------------------
# The strict reader


class _Table:
    """A TOML table read key by key; unknown keys are errors, every error names the key."""

    def __init__(self, source: str, path: str, data: Any):
        self.source = source
        self.path = path
        if not isinstance(data, dict):
            raise ScenarioError(f"{source}: {path or 'top level'} must be a table, got {data!r}")
        self.data = data
        self.used: set[str] = set()

    def key(self, name: str) -> str:
        return f"{self.path}.{name}" if self.path else name

    def fail(self, name: str, value: Any, problem: str) -> ScenarioError:
        if name not in self.data and value is None:
            return ScenarioError(f"{self.source}: {self.key(name)}: {problem}")
        return ScenarioError(f"{self.source}: {self.key(name)} = {value!r}: {problem}")

    def missing(self, name: str, what: str = "required key is missing") -> ScenarioError:
        """A required key is absent; name a present key that looks like a misspelling of it."""
        close = difflib.get_close_matches(name, [str(k) for k in self.data], n=1, cutoff=0.6)
        hint = ""
        if close and close[0] not in self.used:
            value = self.data[close[0]]
            shown = (
                f"[{self.key(close[0])}]"
                if isinstance(value, dict)
                else (f"{self.key(close[0])} = {value!r}")
            )
            hint = f"; unknown key {shown} looks like a misspelling of it"
        where = f"[{self.key(name)}]" if "table" in what else self.key(name)
        return ScenarioError(f"{self.source}: {where}: {what}{hint}")

    def has(self, name: str) -> bool:
        return name in self.data

    def get(self, name: str, kind: type | tuple[type, ...], default: Any = ...) -> Any:
        self.used.add(name)
        if name not in self.data:
            if default is ...:
                raise self.missing(name)
            return default
        value = self.data[name]
        kinds = kind if isinstance(kind, tuple) else (kind,)
        # TOML booleans are not integers here, and integers are accepted where floats are.
        ok = isinstance(value, kinds) and not (isinstance(value, bool) and bool not in kinds)
        if not ok and float in kinds and isinstance(value, int) and not isinstance(value, bool):
            value, ok = float(value), True
        if not ok:
            names = " or ".join(k.__name__ for k in kinds)
            raise self.fail(name, value, f"must be {_article(names)}")
        return value

    def ints(self, name: str, n: int | None = None, default: Any = ...) -> tuple[int, ...]:
        value = self.get(name, list, default)
        if value is default and default is not ...:
            return value
        return self.check_ints(name, value, n)

    def check_ints(self, name: str, value: Any, n: int | None) -> tuple[int, ...]:
        if not isinstance(value, list) or not all(
            isinstance(v, int) and not isinstance(v, bool) for v in value
        ):
            raise self.fail(name, value, "must be a list of integers")
        if n is not None and len(value) != n:
            raise self.fail(name, value, f"must have {n} integers")
        return tuple(value)

    def table(self, name: str, required: bool = True) -> _Table | None:
        self.used.add(name)
        if name not in self.data:
            if required:
                raise self.missing(name, "required table is missing")
            return None
        return _Table(self.source, self.key(name), self.data[name])

    def tables(self, name: str) -> list[_Table]:
        value = self.get(name, list)
        return [_Table(self.source, f"{self.key(name)}[{i}]", v) for i, v in enumerate(value)]

    def finish(self) -> None:
        unknown = sorted(set(self.data) - self.used)
        if unknown:
            name = unknown[0]
            raise self.fail(name, self.data[name], "unknown key (check the spelling)")


def _article(names: str) -> str:
    return ("an " if names[0] in "aeiou" else "a ") + names


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
        self.top = _Table(source, "", data)
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
        top.finish()
        if not comp_tables:
            raise ScenarioError(
                f"{self.source}: components: a scenario needs at least one component"
            )

        ids = self._ids(comp_tables)
        interchangeable = rules.get("interchangeable_targets", bool, False)
        components = [
            self._component(t, ids, random_start is not None, interchangeable) for t in comp_tables
        ]
        order = self._order(rules, ids)
        cranes = rules.get("cranes", int, 1)
        if cranes < 1:
            raise rules.fail("cranes", cranes, "must be at least 1")
        step_limit = rules.get("step_limit", int)
        if step_limit < 1:
            raise rules.fail("step_limit", step_limit, "must be at least 1")
        assembly_steps = rules.get("assembly_steps", int, 1)
        if assembly_steps < 1:
            raise rules.fail("assembly_steps", assembly_steps, "must be at least 1")
        beam_lift_z = rules.get("beam_lift_z", int, None)
        if beam_lift_z is not None and not 1 <= beam_lift_z <= size[2]:
            raise rules.fail("beam_lift_z", beam_lift_z, f"must lie in 1..{size[2]}")
        rules.finish()

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
        )
        _check_geometry(scenario, comp_tables)
        return scenario

    # -- site ------------------------------------------------------------------------------

    def _size(self, site: _Table) -> tuple[int, int, int]:
        size = site.ints("size", 3)
        if any(v < 1 for v in size) or size[0] > 256 or size[1] > 256 or size[2] > 64:
            raise site.fail("size", list(size), "must be 1..256 cells along x and y, height 1..64")
        return size  # type: ignore[return-value]

    def _area(self, site: _Table) -> tuple[int, int, int, int]:
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

    def _foundations(self, site: _Table) -> tuple[tuple[int, int], ...]:
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

    def _obstacles(self, site: _Table) -> tuple[Box, ...]:
        boxes: list[Box] = []
        for t in site.tables("obstacles") if site.has("obstacles") else []:
            lo = t.ints("min", 3)
            hi = t.ints("max", 3)
            t.finish()
            for name, corner in (("min", lo), ("max", hi)):
                if not self._in_site(corner):
                    raise t.fail(name, list(corner), self._outside(corner))
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

    def _in_site(self, cell: tuple[int, ...]) -> bool:
        return self._in_plan(cell) and 1 <= cell[2] <= self.size[2]

    def _outside(self, cell: tuple[int, ...]) -> str:
        x, y, h = self.size
        return f"lies outside the site (x 0..{x - 1}, y 0..{y - 1}, z 1..{h})"

    # -- reward and random start -------------------------------------------------------------

    def _reward(self, t: _Table | None) -> RewardSpec:
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

    def _random_start(self, t: _Table | None) -> RandomStart | None:
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

    # -- components ------------------------------------------------------------------------

    def _ids(self, tables: list[_Table]) -> list[str]:
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

    def _pose(self, t: _Table, name: str, length: int | None) -> Pose:
        raw = t.get(name, list)
        if len(raw) != 2:
            raise t.fail(name, raw, "must be two cells [[x, y, z], [x, y, z]] (node 1, node 2)")
        a = t.check_ints(name, raw[0], 3)
        b = t.check_ints(name, raw[1], 3)
        for cell in (a, b):
            if not self._in_site(cell):
                raise t.fail(name, raw, f"cell {list(cell)} {self._outside(cell)}")
        if not geometry.is_straight(a, b):
            raise t.fail(name, raw, "node 1 and node 2 must lie on one axis-parallel line")
        if length is not None and geometry.pose_length(a, b) != length:
            raise t.fail(name, raw, f"spans {geometry.pose_length(a, b)} cells, length is {length}")
        return (a, b)  # type: ignore[return-value]

    def _component(
        self, t: _Table, ids: list[str], random_start: bool, interchangeable: bool
    ) -> ComponentSpec:
        cid = str(t.get("id", (str, int)))
        kind_name = t.get("kind", str)
        try:
            kind = Kind[kind_name.upper()]
        except KeyError:
            raise t.fail("kind", kind_name, "must be 'column' or 'beam'") from None
        length = t.get("length", int, None)
        if length is not None and length < 1:
            raise t.fail("length", length, "must be at least 1")
        target = self._pose(t, "target", length)
        length = geometry.pose_length(*target)
        axis = geometry.axis_of(*target)
        if kind is Kind.COLUMN and length > 1 and axis != 2:
            raise t.fail("target", t.data["target"], "a column target must stand upright (along z)")
        if kind is Kind.BEAM and axis == 2 and length > 1:
            raise t.fail("target", t.data["target"], "a beam target must lie horizontally")
        prebuilt = t.get("prebuilt", bool, False)
        initial: Pose | None = None
        if t.has("initial"):
            if prebuilt:
                raise t.fail(
                    "initial", t.data["initial"], "a pre-built component has no initial pose"
                )
            initial = self._pose(t, "initial", length)
        elif not prebuilt and not random_start:
            raise t.missing(
                "initial",
                f"required for component {cid!r} "
                "(the scenario has no [random_start] and the component is not pre-built)",
            )
        supports = self._refs(t, "supports", ids)
        if kind is Kind.COLUMN and supports:
            raise t.fail("supports", t.data["supports"], "only beams name supports")
        prebuilt_on = self._refs(t, "prebuilt_on", ids)
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
            kind=kind,
            length=length,
            initial=initial,
            target=target,
            supports=supports,
            prebuilt=prebuilt,
            prebuilt_on=prebuilt_on,
        )

    def _refs(self, t: _Table, name: str, ids: list[str]) -> tuple[int, ...]:
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

    def _order(self, rules: _Table, ids: list[str]) -> tuple[int, ...]:
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


# ---------------------------------------------------------------------------------------------
# Whole-scenario geometry checks


def _check_geometry(s: Scenario, tables: list[_Table]) -> None:
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

    # Columns stand on a foundation or on another column target; beams rest on their supports.
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
        else:
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
            if (other.kind, other.length) != (c.kind, c.length):
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
        from multicrane.start import candidate_poses  # late import: layout imports this module

        for i, c in enumerate(s.components):
            if c.initial is None and not c.prebuilt and not candidate_poses(s, c):
                raise fail(i, "id", "the random start rule has no valid pose for this component")
