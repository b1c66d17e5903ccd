"""Cell geometry of components: poses, cells, shapes, pick-up poses.

A pose is ``(node1, node2)``: the two end cells of an axis-parallel straight component
(column, beam), or two opposite corner cells of a panel (slab, wall: a rectangle one cell
thick); every cell of the box between them belongs to the component. Everything here is pure
Python on a handful of cells; it runs at load and reset time, not in the step.
"""

from __future__ import annotations

from typing import Protocol

from multicrane.core.kinds import kind_spec

Cell = tuple[int, int, int]
Pose = tuple[Cell, Cell]


class StraightComponent(Protocol):
    """What the pick-up rule reads of a component (``multicrane.core.schema.ComponentSpec`` is
    one); geometry stays below the scenario schema and never imports it."""

    @property
    def kind(self) -> int: ...

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


def extent(a: tuple[int, ...], b: tuple[int, ...]) -> tuple[int, int, int]:
    """Cells of the pose's box along x, y and z."""
    return (abs(a[0] - b[0]) + 1, abs(a[1] - b[1]) + 1, abs(a[2] - b[2]) + 1)


def pose_cells(a: tuple[int, ...], b: tuple[int, ...]) -> list[Cell]:
    """The cells of a pose's box, node 1 first and node 2 last: a straight pose from node 1
    to node 2; a panel x-major, walking each axis from node 1's coordinate to node 2's."""
    xs, ys, zs = (
        range(p, q + 1) if q >= p else range(p, q - 1, -1) for p, q in zip(a, b, strict=True)
    )
    return [(x, y, z) for x in xs for y in ys for z in zs]


def shape_key(kind: int, target: Pose) -> tuple[int, tuple[int, int, int]]:
    """What interchangeable components must share: kind and the target's box (for a column
    or beam this is kind, length and axis; lifted components keep their target's shape)."""
    return (int(kind), extent(*target))


def touches(cells_a: list[Cell], cells_b: list[Cell]) -> bool:
    """True when some cell of ``a`` shares a face with some cell of ``b``."""
    b = set(cells_b)
    for x, y, z in cells_a:
        for dx, dy, dz in ((1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)):
            if (x + dx, y + dy, z + dz) in b:
                return True
    return False


def lifted_pose(
    kind: int, length: int, initial: Pose, target: Pose, beam_lift_z: int | None
) -> Pose:
    """Where a component goes when it is picked up: the paper's rule, by its kind's shape
    (``multicrane.core.kinds``).

    A vertical bar (column) is stood upright on node 1's (x, y) and raised by one cell. Every
    other shape is turned about its centre ``(floor((x1 + x2) / 2), floor((y1 + y2) / 2))``
    to the orientation of its own target: a horizontal one (beam, slab) is raised to
    ``beam_lift_z`` (default: the height of its own target), a vertical panel (wall) is stood
    upright on its centre line, one cell up (bottom at ``z + 1``).
    """
    (x1, y1, z1), (x2, y2, _) = initial
    spec = kind_spec(kind)
    if not spec.lifted_about_centre:
        return ((x1, y1, z1 + 1), (x1, y1, z1 + length))
    size = extent(*target)
    lo = [(x1 + x2) // 2, (y1 + y2) // 2, z1 + 1]
    if not spec.upright:
        lo[2] = beam_lift_z if beam_lift_z is not None else target[0][2]
    for axis in (0, 1):
        lo[axis] -= (size[axis] - 1) // 2
    hi = [lo[axis] + size[axis] - 1 for axis in range(3)]
    return ((lo[0], lo[1], lo[2]), (hi[0], hi[1], hi[2]))


def pickup_pose(
    component: StraightComponent, beam_lift_z: int | None, initial: Pose | None = None
) -> Pose:
    """The lifted pose of a component lying at ``initial`` (default: its scenario pose)."""
    start = initial if initial is not None else component.initial
    assert start is not None, "a pre-built component is never picked up"
    return lifted_pose(component.kind, component.length, start, component.target, beam_lift_z)

