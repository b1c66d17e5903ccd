"""The distance oracle against the breadth-first field it stands for, and the carrier's cache.

``multicrane.tasks.distance_oracle`` answers a position's moves to the goal by a reverse search
resumed where it stopped; every answer must be the breadth-first distance over the shape's
field (walls and placed components excluded, the reach included), whatever the order of the
questions. ``ShapeCache`` keeps oracles under the placed components; one kept and one fresh
answer alike.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import multicrane
from multicrane.core.codes import Status
from multicrane.sim.grid_search import breadth_first, fits_everywhere
from multicrane.sim.site import FREE, WALL
from multicrane.tasks.distance_oracle import (
    CLOSED,
    fits_base,
    known_distances,
    lazy_distances,
    resume,
)
from multicrane.tasks.shape_cache import ShapeCache

SIDE = 8
SHAPE = (SIDE, SIDE, SIDE)
DELTAS = np.array([SIDE * SIDE, -SIDE * SIDE, SIDE, -SIDE, 1, -1])
SHAPES = [(0,), (0, 1), (0, SIDE), (0, SIDE * SIDE, 2 * SIDE * SIDE), (0, 1, SIDE, SIDE + 1)]
COORDS = np.stack(np.unravel_index(np.arange(SIDE**3), SHAPE), axis=1).astype(np.int32).ravel()


@st.composite
def worlds(draw):
    """A walled grid with obstacles, components in it (some placed, some in transit, some in
    the yard), a reach mask and a shape: ``(occ, status, static, reach, rel)``."""
    inside = np.array([all(0 < v < SIDE - 1 for v in np.unravel_index(p, SHAPE))
                       for p in range(SIDE**3)])  # fmt: skip
    static = np.where(inside, FREE, WALL).astype(np.int16)
    static[draw(st.lists(st.integers(0, SIDE**3 - 1), max_size=30))] = WALL
    occ = static.copy()
    n_comp = draw(st.integers(0, 6))
    status = np.array(draw(st.lists(st.sampled_from(list(Status)), min_size=n_comp,
                                    max_size=n_comp)), dtype=np.int8)  # fmt: skip
    for c in range(n_comp):
        for j in draw(st.lists(st.integers(0, SIDE**3 - 1), min_size=1, max_size=4)):
            if occ[j] == FREE:
                occ[j] = c + 1
    reach = np.ones(SIDE**3, dtype=np.bool_)
    if draw(st.booleans()):
        reach[draw(st.lists(st.integers(0, SIDE**3 - 1), max_size=200))] = False
    return occ, status, static, reach, draw(st.sampled_from(SHAPES))


def _field(occ, status, static, reach, rel):
    """The shape's field by its definition: clear of walls and placed components, in reach."""
    placed = np.array([v > 0 and status[v - 1] >= Status.ARRIVED for v in occ])
    return fits_everywhere((static != WALL) & ~placed, rel) & reach


@settings(max_examples=200, deadline=None)
@given(worlds(), st.data())
def test_every_answer_is_the_breadth_first_distance(world, data):
    occ, status, static, reach, rel = world
    rel_a = np.asarray(rel, dtype=np.int64)
    goal = data.draw(st.integers(0, SIDE**3 - 1))
    start = data.draw(st.integers(0, SIDE**3 - 1))
    expected = breadth_first(_field(*world), [goal], DELTAS)
    oracle = lazy_distances(occ, status, static, reach, rel_a, COORDS, start, goal)
    order = data.draw(st.permutations(range(SIDE**3)))
    for q in order[:300]:
        assert resume(oracle, occ, status, static, reach, rel_a, COORDS, DELTAS, q) == expected[q]
    n = SIDE**3
    closed = oracle[n : 2 * n] == CLOSED
    assert np.array_equal(oracle[:n][closed], expected[closed])  # what a caller reads
    known = known_distances(expected)
    assert all(resume(known, occ, status, static, reach, rel_a, COORDS, DELTAS, q) == expected[q]
               for q in order[:50])  # fmt: skip


@settings(max_examples=100, deadline=None)
@given(worlds(), st.data())
def test_fits_base_is_the_whole_array_fit(world, data):
    """The base: every cell free or held by a component in transit, in the reach."""
    occ, status, _, reach, rel = world
    transit = np.array([v > 0 and status[v - 1] == Status.IN_TRANSIT for v in occ])
    expected = fits_everywhere((occ == FREE) | transit, rel) & reach
    rel_a = np.asarray(rel, dtype=np.int64)
    for p in data.draw(st.lists(st.integers(0, SIDE**3 - 1), min_size=1, max_size=60)):
        assert fits_base(occ, status, reach, rel_a, p) == expected[p]


def test_the_cache_keeps_oracles_under_the_placed_components():
    """The same question with the same placed components gets the kept oracle (the one
    resumed before); another filled target, a new one; at most ``capacity`` are kept."""
    env = multicrane.parallel_env("hall-4c", n_cranes=4, decisions="task")
    env.reset(seed=3)
    sim = env.unwrapped.sim
    shapes = ShapeCache(sim.site)
    comp = sim.claimable_components()[0]
    pick = sim.state.pickup[comp]
    rel = tuple(j - pick[0] for j in pick)
    goal = env.unwrapped.mode.task_book().carrier.goals[rel, sim.site.compatible[comp][0]]
    first = shapes.oracle(sim, rel, goal, -1, pick[0])
    assert shapes.oracle(sim, rel, goal, -1, pick[0]) is first
    assert shapes.oracle(sim, rel, goal, -1, pick[0] + 1) is not first  # another start
    sim.state.filled[comp] = 0  # as if it had arrived at target 0
    assert shapes.oracle(sim, rel, goal, -1, pick[0]) is not first
    for start in range(shapes.capacity + 5):
        shapes.oracle(sim, rel, goal, -1, start)
    assert len(shapes._oracles) == shapes.capacity
