"""The scenario schema: frozen dataclasses describing a validated site, and ScenarioError.

A scenario is data: these classes hold what a scenario file says, after validation (see
``multicrane.scenario.loader``; the file format is documented in ``scenarios/README.md``).
Nothing here reads files or checks values.
"""

from __future__ import annotations

from dataclasses import dataclass

Cell = tuple[int, int, int]
Pose = tuple[Cell, Cell]  # (node 1, node 2): end cells of a straight component, corners of a panel


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
    """The random initial placement rule, as data (see ``multicrane.sim.start``)."""

    z: int
    bands: tuple[Band, ...]
    directions: tuple[tuple[int, int, int], ...]  # node 2 = node 1 + (length - 1) * direction


@dataclass(frozen=True)
class RewardSpec:
    """Team reward parameters (see ``multicrane.envs.reward``); defaults are the paper's."""

    completion: float = 10.0
    move_limit: int = 15
    over_limit_cost: float = 2.0
    step_cost: float = 1.0


@dataclass(frozen=True)
class CraneSpec:
    """One crane's reach: a tower crane standing at column ``base`` (x, y) reaches every cell
    whose horizontal distance from the base (cell centres, in cells) is at most ``radius``,
    at every height. A component is within reach when all its cells are."""

    base: tuple[int, int]
    radius: float


@dataclass(frozen=True)
class ComponentSpec:
    """One prefabricated component. Its own target has the same index as the component."""

    id: str
    kind: int  # its code in the kind table (multicrane.core.kinds); a Kind for the built-in four
    length: int  # cells (a panel: all the cells of its rectangle)
    initial: Pose | None  # None: pre-built, or drawn by the random start rule
    target: Pose
    supports: tuple[int, ...]  # targets this target rests on (a beam's columns, a panel's)
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
    # Per-crane reach (tower cranes), in crane order; empty: every crane reaches everywhere.
    crane_specs: tuple[CraneSpec, ...] = ()
    # The [events] table: a multicrane.sim.events.EventSpec (not imported here: events builds on
    # the site, which builds on this schema); None: a static site.
    events: object | None = None

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
