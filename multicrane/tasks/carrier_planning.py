"""The carrier's planning: a component's search, and the replans and repairs of plans in transit.

``CarrierPlanning`` is the half of ``multicrane.tasks.carrier.Carrier`` that finds paths: a
space-time search of one component (``_search``: the compiled A* of
``multicrane.tasks.reservation_arrays``, answered from the shared ``SearchMemo`` when it was
asked before), a component in transit planned from where it is to the nearest free ready
targets (``_plan_transit``), every component in transit planned again oldest first
(``_replan_all``, after a plan diverged), and the older plans repaired when a new goal makes a
target able to become ready across their path (``_repair``). The carrier's round (``begin``,
``try_start``, ``actions``) decides when; ``multicrane.tasks.carrier_events.EventCarrier``
overrides the planning of components frozen by site events.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from multicrane.core.codes import Status
from multicrane.tasks.goal_poses import GoalPoses, manhattan
from multicrane.tasks.reservation_arrays import ReservationArrays, compiled_search
from multicrane.tasks.reservations import INF, Plan, shape_of
from multicrane.tasks.search_memo import SearchMemo, remembered
from multicrane.tasks.shape_cache import ShapeCache

if TYPE_CHECKING:
    from multicrane.sim.simulator import Simulator

_IN_TRANSIT = int(Status.IN_TRANSIT)


class CarrierPlanning:
    """Searches, replans and repairs over ``self.plans`` (set by the ``Carrier`` that
    inherits it, with the other attributes below)."""

    sim: Simulator
    plans: dict[int, Plan]
    goals: GoalPoses
    shapes: ShapeCache
    memo: SearchMemo | None
    stats: dict[str, int]
    slack: int
    max_expansions: int
    _seq: dict[int, int]

    def _search(
        self, comp: int, rel: tuple[int, ...], start: int, t_start: int, goal: int,
        stops: set[int], res: ReservationArrays, crane: int, claim: bool = True,
    ) -> list[int] | None:  # fmt: skip
        """Space-time A* (counted in ``stats``; answered by ``memo`` when it has the answer):
        positions from ``t_start`` to the arrival."""
        self.stats["searches"] += 1
        sim = self.sim
        zone = crane if sim.site.reach is not None else -1

        def search():
            shapes = self.shapes
            return compiled_search(
                res, comp, rel, start, t_start, goal, stops, shapes.site_inputs(sim, rel, zone),
                shapes.oracle(sim, rel, goal, zone, start), self.slack, self.max_expansions,
                lifted_onto_goal_arrives=claim,
            )  # fmt: skip

        scalars = (comp, start, t_start, goal, zone, claim, self.slack, self.max_expansions)
        path, expansions = remembered(self.memo, search, sim.state, res, rel, stops, scalars)
        self.stats["expansions"] += expansions
        if path is None:
            self.stats["failed"] += 1
        return path

    def _in_transit(self, comp: int) -> tuple[tuple[int, ...], int, int, set[int]]:
        """A component in transit: its shape, its position, its crane and the targets taken."""
        st = self.sim.state
        rel = shape_of(self.sim, comp)
        return rel, st.cells[comp][0], int(st.holder[comp]), self.taken_targets()

    def _plan_transit(self, comp: int, T: int, res: ReservationArrays) -> bool:
        """Plan a component in transit from where it is; reserve the plan on success."""
        sim = self.sim
        rel, start, crane, taken = self._in_transit(comp)
        here = sim.site.cell(start)
        options = []
        for t in sim.ready_targets(comp):
            if t in taken or not sim.site.reaches(crane, sim.site.target_cells[t]):
                continue
            goal = self.goals[rel, t]
            if goal is not None:
                options.append((manhattan(here, sim.site.cell(goal)), t, goal))
        options.sort()
        for _, t, goal in options[:3]:
            stops = self._stops(comp, rel, t)
            path = self._search(comp, rel, start, T, goal, stops, res, crane, claim=False)
            if path is not None:
                self._replace_transit_plan(comp, crane, t, T, path, rel, res)
                return True
        return False

    def _replace_transit_plan(
        self, comp: int, crane: int, target: int, T: int, path, rel: tuple[int, ...],
        res: ReservationArrays,
    ) -> None:  # fmt: skip
        """Give a component in transit a new plan along ``path``: its old reservations go."""
        res.release(comp)
        plan = Plan(comp, crane, target, T, path, claim=False)
        self._new_plan(plan)
        res.reserve_plan(plan, rel, T)

    def _plan_parked(self, comps: list[int], T: int, res: ReservationArrays) -> list[int]:
        """Plan components in transit that have no plan, in order; returns those still parked."""
        return [comp for comp in comps if not self._plan_transit(comp, T, res)]

    def _replan_all(self, T: int, res: ReservationArrays) -> None:
        """Drop every plan of a component in transit and plan them all again, oldest first."""
        sim = self.sim
        transit = [c for c in range(sim.site.n_components) if sim.state.status[c] == _IN_TRANSIT]
        for c in transit:
            self.plans.pop(c, None)
        res.replace_with(self._fresh_table(T))
        order = sorted(transit, key=lambda c: self._seq.get(c, 0))
        for _ in range(3):
            left = self._plan_parked(order, T, res)
            if not left or len(left) == len(order):
                break
            order = left

    def _repair(self, T: int, res: ReservationArrays, new: set[int]) -> None:
        """Replan the older plans whose path now crosses a target pose that may become ready
        (new goals can make a target ready during the path); keep the old plan if none."""
        sim = self.sim
        for comp, plan in list(self.plans.items()):
            if comp in new or plan.claim or sim.state.status[comp] != _IN_TRANSIT:
                continue
            rel = shape_of(sim, comp)
            stops = self._stops(comp, rel, plan.target)
            rest = plan.positions[max(0, T - plan.t0) : -1]
            if not stops.intersection(rest):
                continue
            self.stats["repairs"] += 1
            saved = res.copy()
            res.release(comp)
            res.hold(sim.state.cells[comp], T, INF, comp)
            del self.plans[comp]
            if not self._plan_transit(comp, T, res):
                res.replace_with(saved)
                self.plans[comp] = plan
