"""A component in transit that stands in its goal pose without having arrived (its target was
not ready when it came) leaves and comes back; a claim lifted onto its goal arrives there."""

from __future__ import annotations

import pytest

import multicrane
import policies
from multicrane.episodes.rollout import run_episode
from multicrane.scenario import generator
from multicrane.tasks.reservations import ReservationTable, space_time_search

# A 3 x 3 x 3 cube of free positions (flat index x * 9 + y * 3 + z) inside a wall ring.
SIDE = 5


def _grid():
    ok = bytearray(SIDE**3)
    for x in range(1, SIDE - 1):
        for y in range(1, SIDE - 1):
            for z in range(1, SIDE - 1):
                ok[(x * SIDE + y) * SIDE + z] = 1
    deltas = [SIDE * SIDE, -SIDE * SIDE, SIDE, -SIDE, 1, -1]
    return bytes(ok), deltas


def _centre() -> int:
    return (2 * SIDE + 2) * SIDE + 2


@pytest.mark.parametrize(("claim", "length"), [(True, 1), (False, 3)])
def test_standing_at_the_goal_arrives_only_for_a_lift(claim, length):
    ok, deltas = _grid()
    goal = _centre()
    h = memoryview(bytearray(0 if p == goal else 1 for p in range(SIDE**3))).cast("b")
    path, _ = space_time_search(
        ReservationTable(), 0, (0,), goal, 5, goal, set(), ok, h, deltas, 10, 1000,
        lifted_onto_goal_arrives=claim,
    )  # fmt: skip
    assert path is not None and len(path) == length
    assert path[0] == path[-1] == goal
    if not claim:
        assert path[1] != goal  # out, and back in: the move into the pose is the arrival


def test_many_cranes_on_a_small_frame_finish():
    """Found by the generator fuzz run: with 14 cranes a beam was lifted onto a target whose
    supports were still being assembled, and waited there in transit for ever."""
    s = generator.generate(
        "frame", 1, bays_x=1, bays_y=2, storeys=3, column_height=3, span=5, cranes=14,
        obstacles=0, yard="around", interchangeable=True, random_start=False, reach=False,
    )  # fmt: skip
    env = multicrane.parallel_env(s)
    result = run_episode(env, policies.make("prioritized", env, seed=0), seed=1)
    assert result["success"], result["steps"]
