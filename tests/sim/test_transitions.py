"""The component state machine, read from its table (``multicrane.sim.transitions``).

Every row of ``TRANSITIONS`` is made to happen on the micro site of ``test_rules`` (in the
multi-agent and the automatic mode), emitting the row's event; every status change not in the
table is refused, both by the table itself and by the simulator, and no action from any
status ever makes one.
"""

from __future__ import annotations

import itertools

import pytest
from test_rules import C1, C1_TO_TARGET, drive, make, micro_site

from multicrane.core.codes import ASSEMBLE, CLAIM_BASE, EventType, Move, Status
from multicrane.sim.transitions import (
    TRANSITIONS,
    TransitionError,
    allowed,
    event_of,
    table_text,
)

ROWS = {(t.source, t.target): t for t in TRANSITIONS}
PAIRS = list(itertools.product(Status, Status))
REFUSED = [(a, b) for a, b in PAIRS if (a, b) not in ROWS]


def reach(status: Status, auto: bool = False):
    """A simulator on the micro site whose component c1 has ``status`` (crane 0 holds it)."""
    sim = make(micro_site(), auto=auto)
    steps = {
        Status.INITIAL: [],
        Status.IN_TRANSIT: [Move.Y_PLUS] if auto else [CLAIM_BASE + C1],
        Status.ARRIVED: [CLAIM_BASE + C1, *C1_TO_TARGET],
        Status.ASSEMBLED: [CLAIM_BASE + C1, *C1_TO_TARGET, ASSEMBLE],
    }[status]
    for action in steps:
        sim.step([int(action)])
    assert sim.state.status[C1] == status
    return sim


# What makes each row happen, per mode, from the state ``reach(row.source)``.
CAUSES = {
    (Status.INITIAL, Status.IN_TRANSIT): {
        False: lambda sim: [sim.step([CLAIM_BASE + C1])],
        True: lambda sim: [sim.step([int(Move.Y_PLUS)])],
    },
    (Status.IN_TRANSIT, Status.ARRIVED): {
        False: lambda sim: drive(sim, C1, C1_TO_TARGET),
        # In automatic mode the lift was the first move; the arrival assembles at once.
        True: lambda sim: drive(sim, C1, C1_TO_TARGET[1:]),
    },
    (Status.ARRIVED, Status.ASSEMBLED): {
        # Automatic mode: no state waits in ARRIVED (the arrival row above covers it).
        False: lambda sim: [sim.step([ASSEMBLE])],
    },
}


def test_the_table_has_a_cause_for_every_row_and_nothing_else():
    assert set(CAUSES) == set(ROWS)
    assert len(ROWS) == len(TRANSITIONS), "one row per status change"
    for row in TRANSITIONS:
        assert row.cause and row.event in EventType
        assert f"{row.source.name} -> {row.target.name}" in table_text()


@pytest.mark.parametrize(
    ("source", "target", "auto"),
    [(*pair, auto) for pair, modes in CAUSES.items() for auto in modes],
)
def test_every_row_happens_and_emits_its_event(source, target, auto):
    sim = reach(source, auto=auto)
    events = [e for out in CAUSES[source, target][auto](sim) for e in out.events]
    events = [e for e in events if e.component == C1]
    assert ROWS[source, target].event in [e.type for e in events]
    if auto and target == Status.ARRIVED:
        assert sim.state.status[C1] == Status.ASSEMBLED  # ... and, at once, the next row
        assert EventType.ASSEMBLED in [e.type for e in events]
    else:
        assert sim.state.status[C1] == target


@pytest.mark.parametrize(("source", "target"), PAIRS)
def test_the_table_refuses_what_it_does_not_list(source, target):
    assert allowed(int(source), int(target)) == ((source, target) in ROWS)
    if (source, target) in ROWS:
        assert event_of(int(source), int(target)) == ROWS[source, target].event
    else:
        with pytest.raises(TransitionError):
            event_of(int(source), int(target))


@pytest.mark.parametrize(("source", "target"), REFUSED)
def test_the_simulator_refuses_a_change_outside_the_table(source, target):
    sim = reach(source)
    with pytest.raises(TransitionError):
        sim._set_status(C1, int(target))
    assert sim.state.status[C1] == source


@pytest.mark.parametrize("source", list(Status))
def test_no_action_makes_a_change_outside_the_table(source):
    sim = reach(source)
    snap = sim.snapshot()
    for action in range(sim.site.n_actions):
        before = sim.state.status.copy()
        sim.step([action])
        for a, b in zip(before.tolist(), sim.state.status.tolist(), strict=True):
            assert a == b or allowed(a, b), f"action {action}: {Status(a).name} -> {Status(b).name}"
        sim.restore(snap)
