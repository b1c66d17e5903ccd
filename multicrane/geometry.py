"""Cell geometry of straight components: poses, cells, pick-up poses.

A pose is ``(node1, node2)``: the two end cells of an axis-parallel straight component; the
cells between them belong to it. Everything here is pure Python on a handful of cells; it runs
at load and reset time, not in the step.
"""

from __future__ import annotations

from typing import Protocol

from multicrane.types import Kind

Cell = tuple[int, int, int]
Pose = tuple[Cell, Cell]


class StraightComponent(Protocol):
    """What the pick-up rule reads of a component (``multicrane.scenario.ComponentSpec`` is
    one); geometry stays below the scenario schema and never imports it."""

    @property
    def kind(self) -> Kind: ...

    @property
    def length(self) -> int: ...

    @property
    def initial(self) -> Pose | None: ...

    @property
    def target(self) -> Pose: ...


def is_straight(a: tuple[int, ...], b: tuple[int, ...]) -> bool:
    """True when the two cells differ along at most one axis."""
    return sum(1 for p, q in zip(a, b, strict=True) if p != q) <= 1


def axis_of(a: tuple[int, ...], b: tuple[int, ...]) -> int:
    """The axis (0 x, 1 y, 2 z) a straight pose runs along; 0 for a single cell."""
    for axis in range(3):
        if a[axis] != b[axis]:
            return axis
    return 0


def pose_length(a: tuple[int, ...], b: tuple[int, ...]) -> int:
    return max(abs(p - q) for p, q in zip(a, b, strict=True)) + 1


def pose_cells(a: tuple[int, ...], b: tuple[int, ...]) -> list[Cell]:
    """The cells of a pose, from node 1 to node 2."""
    n = pose_length(a, b)
    step = tuple((q > p) - (q < p) for p, q in zip(a, b, strict=True))
    return [(a[0] + i * step[0], a[1] + i * step[1], a[2] + i * step[2]) for i in range(n)]


def touches(cells_a: list[Cell], cells_b: list[Cell]) -> bool:
    """True when some cell of ``a`` shares a face with some cell of ``b``."""
    b = set(cells_b)
    for x, y, z in cells_a:
        for dx, dy, dz in ((1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)):
            if (x + dx, y + dy, z + dz) in b:
                return True
    return False


def lifted_pose(
    kind: Kind, length: int, initial: Pose, target: Pose, beam_lift_z: int | None
) -> Pose:
    """Where a component goes when it is picked up (the paper's rule).

    A column is stood upright on node 1's (x, y) and raised by one cell. A beam is raised to
    ``beam_lift_z`` (default: the height of its own target) and turned about its centre
    ``(floor((x1 + x2) / 2), floor((y1 + y2) / 2))`` to the orientation of its own target.
    """
    (x1, y1, z1), (x2, y2, _) = initial
    if kind is Kind.COLUMN:
        return ((x1, y1, z1 + 1), (x1, y1, z1 + length))
    z = beam_lift_z if beam_lift_z is not None else target[0][2]
    centre = [(x1 + x2) // 2, (y1 + y2) // 2]
    axis = axis_of(*target)
    start = list(centre)
    start[axis] -= (length - 1) // 2
    end = list(start)
    end[axis] += length - 1
    return ((start[0], start[1], z), (end[0], end[1], z))


def pickup_pose(
    component: StraightComponent, beam_lift_z: int | None, initial: Pose | None = None
) -> Pose:
    """The lifted pose of a component lying at ``initial`` (default: its scenario pose)."""
    start = initial if initial is not None else component.initial
    assert start is not None, "a pre-built component is never picked up"
    return lifted_pose(component.kind, component.length, start, component.target, beam_lift_z)


def in_site(cell: tuple[int, ...], size: tuple[int, int, int]) -> bool:
    return 0 <= cell[0] < size[0] and 0 <= cell[1] < size[1] and 1 <= cell[2] <= size[2]
