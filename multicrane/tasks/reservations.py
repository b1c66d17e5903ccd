"""Space-time reservations: which component holds which cell when, and A* paths around them.

A component's *position* is its first cell's linear index in the simulator's padded grid and
its *shape* (``rel``) the offsets of its cells from that one; a move adds
``sim.site.move_delta[m]``. Time ``t`` is the simulator's step count: the state at ``t`` is the one
after step ``t``, and actions chosen at decision time ``T`` are applied in step ``T + 1``.

**Why reserved paths never collide, whatever the order the cranes act in.** In each step the
cranes act one after another in a random order, each seeing the site as the earlier ones left
it. So a component may not enter, at ``t``, a cell that another component occupies at ``t``
*or at* ``t - 1`` (no "following" into a cell vacated in the same step, no swaps): for any two
components A and B and any ``t``, ``cells_A(t)`` and ``cells_B(t - 1)`` are disjoint, and so
are ``cells_A(t)`` and ``cells_B(t)``. A move from ``P`` (at ``t - 1``) to ``Q`` (at ``t``)
therefore checks ``Q`` against the reservations at ``t - 1`` and ``t`` and ``P`` against
those at ``t``. Under that rule every reserved move finds its cells free whether the other
cranes have acted yet in the step or not, so it is never blocked.

**The table** (``ReservationTable``) maps a cell to ``(from, to, component)`` intervals; a
path holds its positions step by step and, from its arrival on, its goal pose for ever
(``INF``): an arrived component stays where it is. What never moves during a search (walls,
obstacles, yard components, arrived and assembled ones) is not in the table but in the *base*
(``ok``: where the component's shape fits it; ``multicrane.tasks.distance_oracle.fits_base``).

**Search** (``space_time_search``): A* over (position, time) states, wait or one of the six
moves per step, cost one per step, heuristic the breadth-first distance to the goal around
walls and placed components (``h``; ``multicrane.tasks.distance_oracle``; admissible, since
yard components and components in transit only add detours). A time cap (shortest length +
``slack``) and an expansion cap bound each search. Positions in ``stops`` (poses of other
targets the component would arrive at) are never entered; the goal is entered only once no
other reservation touches its cells from then on (a search whose goal is held up to its time
cap fails at once, without expanding a state: no path could arrive in time).

**Specification and fast path.** ``ReservationTable`` and ``space_time_search`` here are the
readable specification; the carrier runs the same search compiled, on the same reservations
kept as flat rows (``multicrane.tasks.reservation_arrays``, ``multicrane.tasks.search_kernels``),
and the tests check that both give the same paths and expansion counts.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass

from multicrane.core.codes import Status
from multicrane.sim.simulator import NOBODY, Simulator
from multicrane.tasks.goal_poses import GoalPoses

INF = 1 << 40  # "for ever" in the reservation table
_INITIAL, _IN_TRANSIT, _ARRIVED = int(Status.INITIAL), int(Status.IN_TRANSIT), int(Status.ARRIVED)

Interval = tuple[int, int, int]  # (from, to, component), both times included


@dataclass
class Plan:
    """One component's path: ``positions[i]`` at time ``t0 + i``; it arrives at the end."""

    comp: int
    crane: int
    target: int
    t0: int
    positions: list[int]
    claim: bool  # the crane claims the component in step t0 (positions[0]: pick-up pose)

    @property
    def arrival(self) -> int:
        return self.t0 + len(self.positions) - 1

    def at(self, t: int) -> int:
        i = t - self.t0
        return self.positions[i if i < len(self.positions) else -1]

    def move_at(self, t: int) -> int:
        """``at(t + 1) - at(t)``: the position's change in step ``t + 1``."""
        pos = self.positions
        i = t - self.t0
        return pos[i + 1] - pos[i] if i < len(pos) - 1 else 0


class ReservationTable(dict[int, list[Interval]]):
    """Cell -> the intervals during which components hold it (a plain dict underneath)."""

    def hold(self, cells, start: int, end: int, comp: int) -> None:
        """``comp`` holds ``cells`` from ``start`` to ``end`` (``INF``: for ever)."""
        for j in cells:
            self.setdefault(j, []).append((start, end, comp))

    def reserve_path(
        self, comp: int, rel: tuple[int, ...], t0: int, positions: list[int], T: int
    ) -> None:
        """Reserve a path (``positions[i]`` at time ``t0 + i``) from time ``T`` on; the last
        position is held for ever."""
        pos = positions
        i = max(0, T - t0)
        n = len(pos)
        while i < n:
            k = i
            while k + 1 < n and pos[k + 1] == pos[i]:
                k += 1
            end = INF if k == n - 1 else t0 + k
            start = t0 + i
            for r in rel:
                self.setdefault(pos[i] + r, []).append((start, end, comp))
            i = k + 1

    def reserve_plan(self, plan: Plan, rel: tuple[int, ...], T: int) -> None:
        self.reserve_path(plan.comp, rel, plan.t0, plan.positions, T)

    @classmethod
    def of_plans(cls, sim: Simulator, plans: dict[int, Plan], T: int) -> ReservationTable:
        """From time ``T`` on: every component in transit holds its plan's path (or, with no
        plan, its cells for ever), and so does every planned claim of an initial one."""
        return fill_from_plans(cls(), sim, plans, T)

    def release(self, comp: int) -> None:
        """Drop every reservation of ``comp``."""
        for cell in list(self):
            lst = [iv for iv in self[cell] if iv[2] != comp]
            if lst:
                self[cell] = lst
            else:
                del self[cell]

    def conflict(self, cells, lo: int, hi: int, me: int) -> bool:
        """True when another component holds one of ``cells`` at some time in ``lo..hi``."""
        for c in cells:
            lst = self.get(c)
            if lst:
                for a, b, o in lst:
                    if o != me and a <= hi and b >= lo:
                        return True
        return False

    def copy(self) -> ReservationTable:
        """An independent copy (the interval lists are copied too)."""
        return ReservationTable({c: list(v) for c, v in self.items()})


def fill_from_plans(res, sim: Simulator, plans: dict[int, Plan], T: int):
    """Fill the empty table ``res`` (``ReservationTable`` or ``ReservationArrays``) from time
    ``T`` on: every component in transit holds its plan's path (or, with no plan, its cells
    for ever), and so does every planned claim of an initial one; returns it."""
    status = sim.state.status
    for comp in range(sim.site.n_components):
        if status[comp] != _IN_TRANSIT:
            continue
        plan = plans.get(comp)
        if plan is None:
            res.hold(sim.state.cells[comp], T, INF, comp)
        else:
            res.reserve_plan(plan, shape_of(sim, comp), T)
    for plan in plans.values():
        if plan.claim and status[plan.comp] == _INITIAL:
            res.reserve_plan(plan, shape_of(sim, plan.comp), T)
    return res


def shape_of(sim: Simulator, comp: int) -> tuple[int, ...]:
    """The offsets of a component's cells from its first (its pick-up pose's if initial)."""
    st = sim.state
    cells = st.cells[comp] if st.status[comp] == _IN_TRANSIT else st.pickup[comp]
    return tuple(j - cells[0] for j in cells)


def stop_poses(
    sim: Simulator, comp: int, rel: tuple[int, ...], target: int, planned: set[int],
    goals: GoalPoses | None = None,
) -> set[int]:  # fmt: skip
    """Poses (of this shape) of the component's compatible targets other than ``target`` that
    are or may become ready during a path: free, with every support filled or in ``planned``
    (the goals of other paths). A path entering one would arrive there instead. ``goals``:
    the site's cached goal poses (computed here without)."""
    site, filled_by = sim.site, sim.state.filled_by
    goals = GoalPoses(site) if goals is None else goals
    out = set()
    for t in site.compatible[comp]:
        if t == target or filled_by[t] != NOBODY:
            continue
        if all(filled_by[s] != NOBODY or s in planned for s in site.target_supports[t]):
            g = goals[rel, t]
            if g is not None:
                out.add(g)
    return out


def space_time_search(
    res: ReservationTable,
    comp: int,
    rel: tuple[int, ...],
    start: int,
    t_start: int,
    goal: int,
    stops: set[int],
    ok: bytes,
    h: memoryview,
    deltas: list[int],
    slack: int,
    max_expansions: int,
    lifted_onto_goal_arrives: bool = True,
) -> tuple[list[int] | None, int]:
    """Space-time A*: positions from ``t_start`` (at ``start``) to the arrival at ``goal``.

    ``ok``: where the shape fits the base; ``h``: distances to the goal. Returns the path
    (or None) and the number of states expanded. A component arrives by a lift or a move
    into its target pose: a claim lifted onto its goal arrives there
    (``lifted_onto_goal_arrives``), but a component already in transit at its goal did not
    (its target was not ready when it came): its path leaves the goal and comes back.
    """
    h0 = h[start]
    if h0 < 0 or not ok[goal]:
        return None, 0
    free_from = goal_free_from(res, comp, rel, goal, t_start)
    if free_from is None:
        return None, 0
    if start == goal and lifted_onto_goal_arrives:
        return ([start] if t_start >= free_from else None), 0
    t_cap = t_start + h0 + slack
    if free_from >= t_cap:  # a move in needs the goal free the step before it too
        return None, 0  # the goal is held up to the time cap: no arrival in time
    found, parent, expansions = _astar(
        res, comp, rel, start, t_start, goal, stops, ok, h, deltas, t_cap, free_from,
        max_expansions,
    )  # fmt: skip
    if found is None:
        return None, expansions
    return _unwind(parent, found), expansions


def goal_free_from(
    res: ReservationTable, comp: int, rel: tuple[int, ...], goal: int, t_start: int
) -> int | None:
    """The first time from ``t_start`` on after which no other reservation touches the goal's
    cells (the goal is held for ever from the arrival); None when one holds them for ever."""
    free_from = t_start
    for r in rel:
        for _, b, o in res.get(goal + r, ()):
            if o != comp:
                if b >= INF:
                    return None
                free_from = max(free_from, b + 1)
    return free_from


def _astar(
    res: ReservationTable,
    comp: int,
    rel: tuple[int, ...],
    start: int,
    t_start: int,
    goal: int,
    stops: set[int],
    ok: bytes,
    h: memoryview,
    deltas: list[int],
    t_cap: int,
    free_from: int,
    max_expansions: int,
) -> tuple[tuple[int, int] | None, dict, int]:
    """The A* loop of ``space_time_search``: the goal state reached (or None), the parent of
    every state reached, and the number of states expanded."""
    get = res.get

    def conflict_at(p: int, lo: int, hi: int) -> bool:
        """``res.conflict`` of the shape's cells at position p, without building the list."""
        for r in rel:
            lst = get(p + r)
            if lst:
                for a, b, o in lst:
                    if o != comp and a <= hi and b >= lo:
                        return True
        return False

    h0 = h[start]
    parent: dict[tuple[int, int], tuple[int, int] | None] = {(start, t_start): None}
    heap = [(h0, h0, t_start, start)]
    expansions = 0
    found = None
    while heap:
        _, hp, t, p = heapq.heappop(heap)
        expansions += 1
        if expansions > max_expansions:
            break
        if t >= t_cap:
            continue
        t1 = t + 1
        if conflict_at(p, t1, t1):
            continue  # someone enters these cells at t1: it had to leave before
        key = (p, t1)
        if p != goal and key not in parent:  # standing in the goal pose is no arrival
            parent[key] = (p, t)
            heapq.heappush(heap, (t1 - t_start + hp, hp, t1, p))
        for d in deltas:
            q = p + d
            if not ok[q] or q in stops:
                continue
            hq = h[q]
            if hq < 0:
                continue
            key = (q, t1)
            if key in parent:
                continue
            if conflict_at(q, t, t1):
                continue
            if q == goal:
                if t1 < free_from:
                    continue
                parent[key] = (p, t)
                found = key
                break
            parent[key] = (p, t)
            heapq.heappush(heap, (t1 - t_start + hq, hq, t1, q))
        if found is not None:
            break
    return found, parent, expansions


def _unwind(parent: dict, found: tuple[int, int]) -> list[int]:
    """The positions from the search's start to ``found``, following the parents."""
    path = []
    node = found
    while node is not None:
        path.append(node[0])
        node = parent[node]
    path.reverse()
    return path
