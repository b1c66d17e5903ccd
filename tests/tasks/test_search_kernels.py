"""The compiled search against its specification: same distances, same paths, same expansions.

``multicrane.tasks.search_kernels`` (run by the carrier through ``ReservationArrays`` and
``compiled_search``) must answer exactly as ``multicrane.tasks.reservations`` (the dict table
and the Python A* over whole fit and distance arrays) and
``multicrane.sim.grid_search.breadth_first``: hypothesis draws small grids with random
reservation tables, and states of shipped scenarios reached by random legal tasks, and every
search is run both ways, the compiled one with the distances given and found on demand
(``multicrane.tasks.distance_oracle``).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import multicrane
from multicrane.core.codes import Status
from multicrane.episodes.random_actions import random_legal_action
from multicrane.sim.grid_search import breadth_first, fits_everywhere
from multicrane.sim.site import FREE, WALL
from multicrane.tasks import search_kernels, search_scratch
from multicrane.tasks.distance_oracle import known_distances, lazy_distances
from multicrane.tasks.goal_poses import goal_position
from multicrane.tasks.reservation_arrays import ReservationArrays, compiled_search
from multicrane.tasks.reservations import (
    INF,
    ReservationTable,
    goal_free_from,
    shape_of,
    space_time_search,
)
from multicrane.tasks.search_kernels import goal_free_from_kernel
from multicrane.tasks.shape_cache import ShapeCache
from multicrane.tasks.static_paths import breadth_first_kernel

SIDE = 7  # a SIDE^3 grid with a wall ring: flat index (x * SIDE + y) * SIDE + z
DELTAS = [SIDE * SIDE, -SIDE * SIDE, SIDE, -SIDE, 1, -1]
SHAPES = [(0,), (0, 1), (0, SIDE), (0, SIDE * SIDE, 2 * SIDE * SIDE)]


def _inside(p: int) -> bool:
    x, rest = divmod(p, SIDE * SIDE)
    y, z = divmod(rest, SIDE)
    return all(0 < v < SIDE - 1 for v in (x, y, z))


@st.composite
def grids(draw):
    """A free-cell mask (walls around, some obstacles) and a shape."""
    free = np.array([_inside(p) for p in range(SIDE**3)])
    blocked = draw(st.lists(st.integers(0, SIDE**3 - 1), max_size=40))
    free[blocked] = False
    return free, draw(st.sampled_from(SHAPES))


@st.composite
def tables(draw):
    """The same random reservations in both tables (holds, paths, releases)."""
    spec, arrays = ReservationTable(), ReservationArrays(capacity=4)
    for _ in range(draw(st.integers(0, 12))):
        comp = draw(st.integers(0, 4))
        if draw(st.booleans()):
            cells = draw(st.lists(st.integers(0, SIDE**3 - 1), max_size=3))
            start = draw(st.integers(0, 20))
            end = draw(st.sampled_from([INF, start + draw(st.integers(0, 15))]))
            for table in (spec, arrays):
                table.hold(cells, start, end, comp)
        else:
            rel = draw(st.sampled_from(SHAPES))
            positions = draw(st.lists(st.integers(0, SIDE**3 - 60), min_size=1, max_size=12))
            t0, T = draw(st.integers(0, 10)), draw(st.integers(0, 15))
            for table in (spec, arrays):
                table.reserve_path(comp, rel, t0, positions, T)
        if draw(st.integers(0, 5)) == 0:
            gone = draw(st.integers(0, 4))
            for table in (spec, arrays):
                table.release(gone)
    return spec, arrays


def _site(free):
    """The kernel's site inputs for a grid whose free cells are ``free`` (walls elsewhere, no
    components): ``(occ, status, static, reach, coords, deltas)``."""
    occ = np.where(free, FREE, WALL).astype(np.int16)
    coords = np.stack(np.unravel_index(np.arange(SIDE**3), (SIDE,) * 3), axis=1)
    return (occ, np.zeros(0, np.int8), occ, np.ones(SIDE**3, np.bool_),
            coords.astype(np.int32).ravel(), np.array(DELTAS))  # fmt: skip


def _both(spec, arrays, comp, rel, start, t_start, goal, stops, site, ok, h, slack, lifted,
          cap=2000):  # fmt: skip
    """The specification's answer (on bytes and a memoryview, as it was written for, with
    the fit ``ok`` and the distances ``h`` as whole arrays) and the compiled search's, reading
    the fit from ``site`` and the distances given (``known_distances``) and found on demand
    (``lazy_distances``, ``h`` being their breadth-first field): all equal. ``cap``: the
    expansions each may make."""
    occ, status, static, reach, coords, deltas = site
    a = space_time_search(
        spec, comp, rel, start, t_start, goal, stops, bytes(ok), memoryview(h), list(deltas),
        slack, cap, lifted_onto_goal_arrives=lifted,
    )  # fmt: skip
    rel_a = np.asarray(rel, dtype=np.int64)
    oracles = [known_distances(np.asarray(h, dtype=np.int32)),
               lazy_distances(occ, status, static, reach, rel_a, coords, start, goal)]  # fmt: skip
    for oracle in oracles:
        b = compiled_search(
            arrays, comp, rel, start, t_start, goal, stops, site, oracle, slack, cap,
            lifted_onto_goal_arrives=lifted,
        )  # fmt: skip
        assert a == b
    return a


def _kernel_site(site, rel):
    """``site`` as the kernel's helpers take it: ``(occ, status, static, reach, rel, coords,
    deltas)``."""
    occ, status, static, reach, coords, deltas = site
    return occ, status, static, reach, np.asarray(rel, dtype=np.int64), coords, deltas


def _small_scratch_grows(arrays, comp, rel, start, t_start, goal, stops, site, h, slack):
    """A search in scratch space far too small asks for room (``ROOM_*``) until it fits and
    then answers as one in ample space: the same path and expansions."""
    rel = np.asarray(rel, dtype=np.int64)
    stop = np.zeros(SIDE**3, dtype=np.bool_)
    stop[list(stops)] = True
    occ, status, static, reach, coords, deltas = site
    answers, rooms = [], set()
    for scratch in (search_scratch.search_scratch(SIDE**3, 0, 0, 1, 1),
                    search_scratch.search_scratch(SIDE**3, 4096, 1 << 16, 1 << 15, 4096)):
        while True:
            length, expansions = search_kernels.space_time_search_into(
                arrays.rows, arrays.n, comp, rel, start, t_start, goal, stop, occ, status,
                static, reach, coords, deltas, known_distances(np.asarray(h, dtype=np.int32)),
                slack, 2000, True, INF, scratch,
            )  # fmt: skip
            if length >= 0:
                break
            rooms.add(length)
            scratch = search_scratch.grown_scratch(scratch, length, arrays.n)
        answers.append((scratch.path[:length].copy(), expansions))
    assert answers[0][1] == answers[1][1] and np.array_equal(answers[0][0], answers[1][0])
    return rooms


@settings(max_examples=150, deadline=None)
@given(grids(), st.data())
def test_breadth_first_kernel_is_the_grid_search(grid, data):
    free, rel = grid
    ok = fits_everywhere(free, rel)
    goal = data.draw(st.integers(0, SIDE**3 - 1))
    expected = breadth_first(ok, [goal], DELTAS)
    assert np.array_equal(breadth_first_kernel(ok, goal, np.array(DELTAS)), expected)


def test_breadth_first_kernel_refuses_other_than_six_moves():
    ok = np.ones(SIDE**3, dtype=bool)
    with pytest.raises(ValueError, match="six moves"):
        breadth_first_kernel(ok, 0, np.array(DELTAS[:4]))


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(grids(), tables(), st.data())
def test_compiled_search_is_the_specification(grid, both, data):
    free, rel = grid
    spec, arrays = both
    ok = fits_everywhere(free, rel)
    places = np.flatnonzero(ok)
    if places.size < 2:
        return
    pick = st.sampled_from(places.tolist())
    start, goal = data.draw(pick), data.draw(pick)
    stops = set(data.draw(st.lists(pick, max_size=3))) - {start, goal}
    comp, t_start = data.draw(st.integers(0, 4)), data.draw(st.integers(0, 12))
    h = breadth_first(ok, [goal], DELTAS)
    slack, lifted = data.draw(st.integers(0, 12)), data.draw(st.booleans())
    cap = data.draw(st.sampled_from([2000, 0, 1, 3, 10, 30, 100, 300]))
    site = _site(free)
    _both(spec, arrays, comp, rel, start, t_start, goal, stops, site, ok, h, slack, lifted, cap)
    _below_is_expanded_first(spec, arrays, comp, rel, start, t_start, goal, stops, site, ok, h,
                             slack)  # fmt: skip
    _small_scratch_grows(arrays, comp, rel, start, t_start, goal, stops, site, h, slack)
    cells = [start + r for r in rel]
    lo = data.draw(st.integers(0, 25))
    hi = lo + data.draw(st.integers(0, 5))
    assert spec.conflict(cells, lo, hi, comp) == arrays.conflict(cells, lo, hi, comp)
    free_from = goal_free_from(spec, comp, rel, goal, t_start)
    kernel = goal_free_from_kernel(arrays.rows, arrays.n, comp, np.array(rel), goal, t_start, INF)
    assert (free_from if free_from is not None else -1) == kernel


def _below_is_expanded_first(spec, arrays, comp, rel, start, t_start, goal, stops, site, ok, h,
                             slack):  # fmt: skip
    """The count of states below the goal's free time (``_states_below``, which lets a
    search over its cap fail at once) never exceeds what the specification's A* expands
    (without a cap) before it finds the goal or runs out of states."""
    rel_a = np.asarray(rel, dtype=np.int64)
    free_from = goal_free_from_kernel(arrays.rows, arrays.n, comp, rel_a, goal, t_start, INF)
    if h[start] < 0 or free_from < 0 or start == goal or not ok[goal]:
        return
    stop = np.zeros(len(ok), dtype=np.bool_)
    stop[list(stops)] = True
    scratch = search_scratch.search_scratch(ok.size, arrays.n)
    search_kernels._cell_lists(arrays.rows, arrays.n, comp, t_start, scratch.head, scratch.nxt)
    below = min(free_from, t_start + h[start] + slack) - t_start
    count = search_kernels._states_below(
        arrays.rows, scratch.head, scratch.nxt, rel_a, start, t_start, goal, stop,
        _kernel_site(site, rel), known_distances(np.asarray(h, dtype=np.int32)), below, 10**9,
        scratch,
    )  # fmt: skip
    _, expanded = space_time_search(
        spec, comp, rel, start, t_start, goal, stops, bytes(ok), memoryview(h), DELTAS, slack,
        10**9,
    )  # fmt: skip
    if free_from < t_start + h[start] + slack:  # else the search fails before expanding
        assert count <= expanded


def test_a_late_goal_over_the_cap_fails_as_the_specification():
    """The goal is held until step 10 (start 4 moves away, slack 12): every state of f below
    11 comes before the goal. Under a cap below their count both searches fail with cap + 1
    expansions (the kernel without expanding them); above it both find the path."""
    free = np.array([_inside(p) for p in range(SIDE**3)])
    ok = fits_everywhere(free, (0,))
    start, goal = (SIDE + 1) * SIDE + 1, (SIDE + 1) * SIDE + 5  # (1, 1, 1) and (1, 1, 5)
    h = breadth_first(ok, [goal], DELTAS)
    spec, arrays = ReservationTable(), ReservationArrays()
    for table in (spec, arrays):
        table.hold([goal], 0, 10, 9)
    scratch = search_scratch.search_scratch(ok.size, arrays.n)
    search_kernels._cell_lists(arrays.rows, arrays.n, 0, 0, scratch.head, scratch.nxt)
    site = _site(free)
    count = search_kernels._states_below(
        arrays.rows, scratch.head, scratch.nxt, np.zeros(1, dtype=np.int64), start, 0, goal,
        np.zeros(ok.size, dtype=np.bool_), _kernel_site(site, (0,)), known_distances(h), 11,
        10**9, scratch,
    )  # fmt: skip
    assert count > 100
    for cap in (0, 1, count // 2, count - 1, count, count + 1, 10 * count):
        path, expansions = _both(spec, arrays, 0, (0,), start, 0, goal, set(), site, ok, h, 12,
                                 True, cap)  # fmt: skip
        if cap < count:
            assert path is None and expansions == cap + 1
    assert path is not None and len(path) - 1 == 12  # free from 11: entered at 12


@pytest.mark.parametrize(("held_until", "arrival"), [(None, 4), (10, 12), (11, None),
                                                      (40, None)])  # fmt: skip
def test_a_goal_held_up_to_the_time_cap_fails_at_once(held_until, arrival):
    """Start and goal 4 moves apart, slack 8: the time cap is step 12, the last arrival. A
    move into the goal at ``t`` needs it free at ``t - 1`` and ``t``: held until 10, it is
    entered at 12; held until 11 or later it cannot be entered in time, and both searches
    fail without expanding a state."""
    free = np.array([_inside(p) for p in range(SIDE**3)])
    ok = fits_everywhere(free, (0,))
    start, goal = (SIDE + 1) * SIDE + 1, (SIDE + 1) * SIDE + 5  # (1, 1, 1) and (1, 1, 5)
    h = breadth_first(ok, [goal], DELTAS)
    assert h[start] == 4
    spec, arrays = ReservationTable(), ReservationArrays()
    if held_until is not None:
        for table in (spec, arrays):
            table.hold([goal], 0, held_until, 9)
    path, expansions = _both(spec, arrays, 0, (0,), start, 0, goal, set(), _site(free), ok, h,
                             8, True)  # fmt: skip
    if arrival is None:
        assert path is None and expansions == 0
    else:
        assert path[0] == start and path[-1] == goal and len(path) - 1 == arrival


def test_copies_and_replacement_are_independent():
    table = ReservationArrays(capacity=1)
    table.hold([5, 6], 0, INF, 1)
    assert table[5] == [(0, INF, 1)]
    saved = table.copy()
    table.release(1)
    assert not table.conflict([5], 0, 3, 0) and saved.conflict([5], 0, 3, 0)
    table.replace_with(saved)
    saved.release(1)
    assert table.conflict([6], 2, 2, 0) and not saved.conflict([6], 2, 2, 0)


SITES = [("e2s2", 2), ("e3s2", 3), ("hall-4c", 4), ("towers-3c", 3), ("precast-house", 2)]


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(SITES), st.integers(0, 10_000), st.integers(0, 25))
def test_searches_on_shipped_sites_are_the_specification(site, seed, rounds):
    """From a state reached by random legal tasks, every ready (component, target) pair and
    crane is searched both ways against both tables of the carrier's plans."""
    scenario, n = site
    env = multicrane.parallel_env(scenario, n_cranes=n, decisions="task")
    observations, _ = env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    for _ in range(rounds):
        if not env.agents:
            return
        actions = {}
        for a in env.agents:
            mask = observations[a]["action_mask"]
            actions[a] = random_legal_action(mask, rng) if mask[1:].any() else 0
        observations, *_ = env.step(actions)
    book = env.unwrapped.mode.task_book()
    sim, carrier = env.unwrapped.sim, book.carrier
    T = sim.state.step_count
    spec = ReservationTable.of_plans(sim, carrier.plans, T)
    arrays = ReservationArrays.of_plans(sim, carrier.plans, T)
    shapes, deltas = ShapeCache(sim.site), sim.site.move_delta
    zones = [-1] if sim.site.reach is None else list(range(n))

    def fields(rel, goal, zone):
        """The specification's fit and distances as whole arrays: the base free but for
        components in transit, and breadth-first moves around walls and placed components."""
        st = sim.state
        transit = [j for c in range(len(st.status)) if st.status[c] == Status.IN_TRANSIT
                   for j in st.cells[c]]  # fmt: skip
        placed = [j for c in range(len(st.status)) if st.status[c] >= Status.ARRIVED
                  for j in st.cells[c]]  # fmt: skip
        base, field = st.occ == FREE, sim.site.static != WALL
        base[transit], field[placed] = True, False
        reach = shapes.reach(rel, zone)
        ok = fits_everywhere(base, rel) & reach
        return ok, breadth_first(fits_everywhere(field, rel) & reach, [goal], deltas)

    for comp in sim.claimable_components():  # claims: from the pick-up pose, lifted
        pick = sim.state.pickup[comp]
        rel = tuple(j - pick[0] for j in pick)
        for target in sim.ready_targets(comp)[:3]:
            goal = goal_position(rel, sim.site.target_cells[target])
            if goal is None:
                continue
            zone = zones[(comp + target) % len(zones)]
            ok, h = fields(rel, goal, zone)
            stops = carrier._stops(comp, rel, target)
            _both(spec, arrays, comp, rel, pick[0], T + 1, goal, stops,
                  shapes.site_inputs(sim, rel, zone), ok, h, 40, True)  # fmt: skip
    for comp, plan in carrier.plans.items():  # components in transit: from where they are
        if plan.claim:
            continue
        rel = shape_of(sim, comp)
        goal, start = plan.positions[-1], sim.state.cells[comp][0]
        ok, h = fields(rel, goal, -1)
        stops = carrier._stops(comp, rel, plan.target)
        _both(spec, arrays, comp, rel, start, T, goal, stops, shapes.site_inputs(sim, rel, -1),
              ok, h, 40, False)  # fmt: skip
