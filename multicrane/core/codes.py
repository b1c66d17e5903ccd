"""Integer codes shared by every module.

Axis convention, used everywhere: a cell is ``(x, y, z)``; ``x`` and ``y`` are the horizontal
indices, ``z`` points up. ``z = 0`` is the ground, which nothing may enter; components live at
``z = 1 .. height``.
"""

from __future__ import annotations

from enum import IntEnum
from typing import NamedTuple


class Kind(IntEnum):
    """What a component is: the codes of the built-in kinds, whose rules are their entries in
    ``multicrane.core.kinds``. Components of the same kind and shape are interchangeable."""

    COLUMN = 0
    BEAM = 1
    SLAB = 2  # a floor or roof panel: a horizontal rectangle one cell thick
    WALL = 3  # a wall panel: a vertical rectangle one cell thick


class Status(IntEnum):
    """The state machine of a component: it only ever moves forward, one step at a time."""

    INITIAL = 0  # lying in the yard
    IN_TRANSIT = 1  # lifted, carried by a crane
    ARRIVED = 2  # covers a free target it may fill; waits for assembly
    ASSEMBLED = 3  # built in; never moves again


class Move(IntEnum):
    """The six moves, numbered as in the paper's action table."""

    X_MINUS = 0
    Y_MINUS = 1
    X_PLUS = 2
    Y_PLUS = 3
    UP = 4
    DOWN = 5


# (dx, dy, dz) of each move, indexed by ``Move``.
MOVE_DELTAS: tuple[tuple[int, int, int], ...] = (
    (-1, 0, 0),
    (0, -1, 0),
    (1, 0, 0),
    (0, 1, 0),
    (0, 0, 1),
    (0, 0, -1),
)

N_MOVES = 6
WAIT = 6  # crane action: do nothing this step
ASSEMBLE = 7  # crane action: assemble the arrived component it holds
CLAIM_BASE = 8  # crane action CLAIM_BASE + i: claim component i (scenario order)


class EventType(IntEnum):
    """What can happen to a crane or a component during a step."""

    CLAIMED = 0  # a crane took a component (multi-agent claiming)
    LIFTED = 1  # a component left the yard and is in transit
    BLOCKED = 2  # a move was refused: bounds, obstacle or another component
    LIFT_BLOCKED = 3  # the pick-up pose was not free; the component stays in the yard
    CLAIM_CONFLICT = 4  # another crane claimed the same component first this step
    ARRIVED = 5  # a component covers a target it may fill
    ASSEMBLY_STARTED = 6  # a crane began assembling an arrived component
    ASSEMBLED = 7  # a component is built in; its crane is free again
    PASS_OVER = 8  # automatic mode: a pre-built list entry used up the step (paper quirk)
    ILLEGAL = 9  # an action the mask did not allow was sent; it did nothing
    ASSIGNED = 10  # automatic mode: the list pointer gave a crane its next component


class Event(NamedTuple):
    """One thing that happened. ``component`` and ``target`` are -1 where they do not apply."""

    step: int
    crane: int
    type: EventType
    component: int = -1
    target: int = -1
    detail: str = ""


class SiteEventType(IntEnum):
    """What the site's event schedule (``multicrane.sim.events``) did as time reached a step."""

    DELIVERED = 0  # a late component appeared in the yard (``component``)
    CRANE_DOWN = 1  # a crane broke down (``crane``)
    CRANE_UP = 2  # a crane is available again (``crane``)
    ZONE_CLOSED = 3  # a closure came into force (``closure``: its index in the schedule)
    ZONE_OPENED = 4  # a closure ended (``closure``)


class SiteEvent(NamedTuple):
    """One site event at time ``step``; fields that do not apply are -1."""

    step: int
    type: SiteEventType
    crane: int = -1
    component: int = -1
    closure: int = -1
