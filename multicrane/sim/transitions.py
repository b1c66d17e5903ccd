"""The component state machine as one table: which status changes exist and what causes them.

A component starts an episode ``INITIAL`` (lying in the yard) or, if pre-built, ``ASSEMBLED``;
after that its status only changes along ``TRANSITIONS``. The simulator asks ``event_of``
before every status change (a change not in the table raises ``TransitionError``), the
environments' docstrings print ``table_text()``, and ``tests/sim/test_transitions.py`` drives
every row and checks every other change is refused.
"""

from __future__ import annotations

import textwrap
from typing import NamedTuple

from multicrane.core.codes import EventType, Status


class Transition(NamedTuple):
    """One allowed status change: ``source -> target``, the event it emits, its cause."""

    source: Status
    target: Status
    event: EventType
    cause: str


TRANSITIONS: tuple[Transition, ...] = (
    Transition(
        Status.INITIAL,
        Status.IN_TRANSIT,
        EventType.LIFTED,
        "lift: a claim action (multi-agent mode) or the first move of an assigned component "
        "(automatic mode) when its pick-up pose is free",
    ),
    Transition(
        Status.IN_TRANSIT,
        Status.ARRIVED,
        EventType.ARRIVED,
        "arrival: a lift or move leaves the component exactly on a ready compatible target",
    ),
    Transition(
        Status.ARRIVED,
        Status.ASSEMBLED,
        EventType.ASSEMBLED,
        "assembly: the assemble action, completed after assembly_steps steps (multi-agent "
        "mode); at once on arrival (automatic mode)",
    ),
)

# (source, target) as plain ints -> the event: the simulator's check is one dict lookup.
_EVENTS: dict[tuple[int, int], EventType] = {
    (int(t.source), int(t.target)): t.event for t in TRANSITIONS
}


class TransitionError(RuntimeError):
    """A status change that the state machine does not allow."""


def allowed(source: int, target: int) -> bool:
    """True when ``source -> target`` is a row of the table."""
    return (source, target) in _EVENTS


def event_of(source: int, target: int) -> EventType:
    """The event a status change emits; ``TransitionError`` if the table has no such row."""
    try:
        return _EVENTS[source, target]
    except KeyError:
        raise TransitionError(
            f"no transition {Status(source).name} -> {Status(target).name} in the state machine"
        ) from None


def table_text(width: int = 88) -> str:
    """The table as text, one list item per row wrapped at ``width`` (for docstrings, help)."""
    return "\n".join(
        textwrap.fill(
            f"- ``{t.source.name} -> {t.target.name}`` (event ``{t.event.name}``): {t.cause}.",
            width,
            subsequent_indent="  ",
        )
        for t in TRANSITIONS
    )
