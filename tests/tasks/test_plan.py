"""``Plan.move_at(t)``, the step the carrier turns into a motion action, is ``at(t + 1) - at(t)``
at every time: before the plan starts, along it, at its end and after it."""

from __future__ import annotations

import pytest

from multicrane.tasks.reservations import Plan


@pytest.mark.parametrize("positions", [[5], [5, 6], [5, 6, 6, 13, 12], [9, 9, 9]])
@pytest.mark.parametrize("t0", [0, 3])
def test_move_at_is_the_difference_of_positions(positions, t0):
    plan = Plan(comp=0, crane=0, target=0, t0=t0, positions=positions, claim=True)
    for t in range(t0 - 1, t0 + len(positions) + 3):
        assert plan.move_at(t) == plan.at(t + 1) - plan.at(t), t


def test_move_at_reads_the_moves_in_order():
    plan = Plan(comp=0, crane=0, target=0, t0=10, positions=[5, 6, 6, 13, 12], claim=False)
    assert [plan.move_at(t) for t in range(10, 16)] == [1, 0, 7, -1, 0, 0]
