"""Prioritized planning with space-time reservations: a centralised multi-crane planner.

Every component a crane carries follows a path planned in space *and time* (cooperative A*,
one component after another in priority order) against a reservation table holding the
paths already planned, so that the planned paths never collide. Idle cranes are given ready
components by a greedy assignment on estimated cost, and a component is claimed only when a
collision-free path from its pick-up pose to a free ready target exists. It reads the
simulator state (a planner, not a learned policy) and acts through ``MultiCraneEnv``'s own
actions in the default (claiming) mode: claim ``8 + i``, moves ``0..5``, wait ``6``,
assemble ``7``.

    planner = PrioritizedPlanner(env)
    observations, _ = env.reset(seed=0)
    while env.agents:
        observations, *_ = env.step(planner(observations))

**Paths and reservations** (``multicrane.reservations``): a planned move is never blocked,
whatever order the cranes act in. A claim lifts the component to its pick-up pose in the
claim step, so the pose must be free of reservations then; the search starts there. A
component in transit with no plan (after a failed search) holds its cells for ever until it
gets one; no new claims are made meanwhile.

**Targets and search.** A component arrives whenever its cells cover a ready compatible
target, so paths never enter the pose of another compatible target that is, or may become
during the path, ready (``reservations.stop_poses``). A failed search
(``reservations.space_time_search``) means "not now": the crane waits and tries again at the
next decision.

**Assignment and replanning.** Ready pairs (claimable component, free ready target not
already the goal of a plan) are ranked and taken greedily, each idle crane getting the best
pair whose search succeeds (components in transit keep the priority of their earlier plans;
newer ones plan around them). ``rank="list"`` (default) ranks by the component's place in the
scenario's list order (a buildable order, columns before the beams they carry), then by the
Manhattan distance from the pick-up pose to the target; ``rank="nearest"`` by that distance
alone. Building in list order leaves fewer finished components in the way of later paths:
over the shipped scenarios with 1-4 cranes (5 seeds) it gave makespans about 3 % shorter
on average than nearest-first (up to 19 %: e4s3 with 3 cranes; 12 % on hall-4c with 4).

Each decision checks that every component is where its plan says. If one is not (an
arrival the plan did not foresee, a claim that failed; neither was seen on the shipped
scenarios), every plan is dropped and all components in transit are planned again, oldest
first, in up to three passes. When new goals make a target able to become ready while an
older plan's path crosses its pose, that plan is replanned (the old one is kept if no new
one is found), so that the component does not arrive there by accident.
"""

from __future__ import annotations

from multicrane.reservations import (
    INF,
    Plan,
    ReservationTable,
    ShapeCache,
    goal_position,
    manhattan,
    shape_of,
    space_time_search,
    stop_poses,
)
from multicrane.simulator import NOBODY, Simulator
from multicrane.types import ASSEMBLE, CLAIM_BASE, WAIT, Status

_INITIAL, _IN_TRANSIT, _ARRIVED, _ASSEMBLED = (int(s) for s in Status)


class PrioritizedPlanner:
    """Drive a ``MultiCraneEnv`` (default mode, any number of cranes) by prioritized planning.

    ``seed`` is accepted for the same signature as ``GreedyPolicy``; the planner itself is
    deterministic. ``slack``: how many steps past the shortest path length a search may run
    (waiting for other components); ``max_expansions``: A* states expanded per search at
    most; ``max_searches``: new-claim searches per decision at most; ``rank``: ``"list"`` or
    ``"nearest"`` (how ready components are chosen, see above). ``stats`` counts searches,
    failures, expansions, claims, full replans, path repairs and fallbacks (a planned action
    the mask did not allow: the crane waits and everything is replanned; should stay 0).
    """

    def __init__(
        self,
        env,
        seed: int | None = 0,
        slack: int = 40,
        max_expansions: int = 20000,
        max_searches: int = 8,
        rank: str = "list",
    ):
        if env.sim.auto:
            raise ValueError("PrioritizedPlanner drives the default (claiming) mode, not auto=True")
        self.env = env
        self.seed = seed
        self.slack = slack
        self.max_expansions = max_expansions
        self.max_searches = max_searches
        if rank not in ("list", "nearest"):
            raise ValueError(f"rank must be 'list' or 'nearest', got {rank!r}")
        self.rank = rank
        self._list_rank = {c: i for i, c in enumerate(env.scenario.order)}
        self.stats = dict.fromkeys(
            ("searches", "failed", "expansions", "claims", "replans", "repairs", "fallbacks"), 0
        )
        self._setup()
        self.reset()

    @property
    def sim(self) -> Simulator:
        return self.env.sim

    def _setup(self) -> None:
        sim = self.sim
        self._move_of = {d: m for m, d in enumerate(sim.site.move_delta)}
        self._deltas = list(sim.site.move_delta)
        self._sim_id = id(sim)

    def reset(self) -> None:
        """Forget every plan (called automatically at the start of an episode)."""
        self.plans: dict[int, Plan] = {}
        self._seq: dict[int, int] = {}  # comp -> plan creation number (the priority)
        self._counter = 0
        self._last_t: int | None = None
        self._cached: dict | None = None
        self._shapes = ShapeCache(self.sim)
        self._force_replan = False

    # -- the policy call -------------------------------------------------------------------

    def __call__(self, observations: dict) -> dict:
        sim = self.sim
        if id(sim) != self._sim_id:
            self._setup()
            self.reset()
        T = sim.state.step_count
        if T == 0 or self._last_t is None or self._last_t > T:
            self.reset()
        elif self._last_t == T and self._cached is not None:
            return dict(self._cached)
        self._last_t = T
        agents = self.env.possible_agents
        masks = [observations[a]["action_mask"] for a in agents] if observations else None

        diverged = self._sync(T) or self._force_replan
        self._force_replan = False
        status = sim.state.status
        transit = [c for c in range(sim.site.n_components) if status[c] == _IN_TRANSIT]
        unplanned = [c for c in transit if c not in self.plans]
        idle = [
            crane
            for crane in range(sim.n_cranes)
            if sim.state.held[crane] == NOBODY
            and not sim.state.assembling[crane]
            and not sim.state.pass_over[crane]
        ]
        candidates = [c for c in sim.claimable_components() if c not in self.plans]
        claims: dict[int, int] = {}
        if diverged or unplanned or (idle and candidates):
            res = self._reservations(T)
            if diverged:
                self.stats["replans"] += 1
                self._replan_all(T, res)
            elif unplanned:
                self._plan_parked(unplanned, T, res)
            parked = [c for c in transit if c not in self.plans]
            if idle and candidates and not parked:
                claims = self._assign(idle, candidates, T, res)
                if claims:
                    self._repair(T, res, set(claims.values()))

        actions = {}
        for crane, agent in enumerate(agents):
            a = self._action(crane, T, claims)
            if masks is not None and not masks[crane][a]:
                # Should not happen: the plan disagrees with the site. Wait and replan all.
                self.stats["fallbacks"] += 1
                self._force_replan = True
                a = WAIT
            actions[agent] = a
        self._cached = actions
        return dict(actions)

    def _action(self, crane: int, T: int, claims: dict[int, int]) -> int:
        sim = self.sim
        if sim.state.assembling[crane] or sim.state.pass_over[crane]:
            return WAIT
        comp = sim.state.held[crane]
        if comp == NOBODY:
            return CLAIM_BASE + claims[crane] if crane in claims else WAIT
        if sim.state.status[comp] == _ARRIVED:
            return ASSEMBLE
        plan = self.plans.get(comp)
        if plan is None:
            return WAIT
        d = plan.at(T + 1) - plan.at(T)
        return WAIT if d == 0 else self._move_of[d]

    # -- bookkeeping -------------------------------------------------------------------------

    def _sync(self, T: int) -> bool:
        """Drop finished plans; True when some component is not where its plan says."""
        sim = self.sim
        diverged = False
        for comp, plan in list(self.plans.items()):
            s = sim.state.status[comp]
            if s == _INITIAL:
                if plan.claim and plan.t0 > T:
                    continue  # claimed in the coming step
                diverged = True  # the claim failed
                del self.plans[comp]
            elif s == _IN_TRANSIT:
                if plan.t0 > T or sim.state.cells[comp][0] != plan.at(T) or plan.arrival <= T:
                    diverged = True
                    del self.plans[comp]
            else:  # arrived or assembled: as planned, or somewhere else
                if sim.state.filled[comp] != plan.target or plan.arrival != self._arrived_at(
                    comp, T
                ):
                    diverged = True
                del self.plans[comp]
        return diverged

    def _arrived_at(self, comp: int, T: int) -> int:
        """When an arrived component arrived (the plan's arrival if it did as planned)."""
        plan = self.plans[comp]
        if self.sim.state.cells[comp][0] == plan.positions[-1] and plan.arrival <= T:
            return plan.arrival
        return -1

    def _new_plan(self, plan: Plan) -> None:
        self.plans[plan.comp] = plan
        if plan.comp not in self._seq:
            self._counter += 1
            self._seq[plan.comp] = self._counter

    def _reservations(self, T: int) -> ReservationTable:
        return ReservationTable.of_plans(self.sim, self.plans, T)

    def _rel(self, comp: int) -> tuple[int, ...]:
        return shape_of(self.sim, comp)

    def _reserve_plan(self, res: ReservationTable, plan: Plan, T: int) -> None:
        res.reserve_plan(plan, self._rel(plan.comp), T)

    # -- geometry ------------------------------------------------------------------------------

    def _goal(self, rel: tuple[int, ...], target: int) -> int | None:
        """The position at which a component of this shape covers the target exactly."""
        return goal_position(rel, self.sim.site.target_cells[target])

    def _stops(self, comp: int, rel: tuple[int, ...], target: int) -> set[int]:
        """Poses of other compatible targets that are or may become ready during a path."""
        planned = {p.target for c, p in self.plans.items() if c != comp}
        return stop_poses(self.sim, comp, rel, target, planned)

    def _taken_targets(self) -> set[int]:
        return {p.target for p in self.plans.values()}

    # -- planning ------------------------------------------------------------------------------

    def _search(
        self, comp: int, rel: tuple[int, ...], start: int, t_start: int, goal: int,
        stops: set[int], res: ReservationTable, crane: int | None = None,
    ) -> list[int] | None:  # fmt: skip
        """Space-time A* (counted in ``stats``): positions from ``t_start`` to the arrival,
        inside ``crane``'s zone under crane reach."""
        self.stats["searches"] += 1
        sim = self.sim
        ok = self._shapes.base_ok(sim, rel, crane)
        h = self._shapes.heuristic(sim, rel, goal)
        path, expansions = space_time_search(
            res, comp, rel, start, t_start, goal, stops, ok, h,
            self._deltas, self.slack, self.max_expansions,
        )  # fmt: skip
        self.stats["expansions"] += expansions
        if path is None:
            self.stats["failed"] += 1
        return path

    def _plan_transit(self, comp: int, T: int, res: ReservationTable) -> bool:
        """Plan a component in transit from where it is; reserve the plan on success."""
        sim = self.sim
        rel = self._rel(comp)
        start = sim.state.cells[comp][0]
        taken = self._taken_targets()
        here = sim.site.cell(start)
        options = []
        for t in sim.ready_targets(comp):
            if t in taken:
                continue
            goal = self._goal(rel, t)
            if goal is not None:
                options.append((manhattan(here, sim.site.cell(goal)), t, goal))
        options.sort()
        crane = int(sim.state.holder[comp])
        for _, t, goal in options[:3]:
            stops = self._stops(comp, rel, t)
            path = self._search(comp, rel, start, T, goal, stops, res, crane)
            if path is not None:
                res.release(comp)
                plan = Plan(comp, crane, t, T, path, claim=False)
                self._new_plan(plan)
                self._reserve_plan(res, plan, T)
                return True
        return False

    def _plan_parked(self, comps: list[int], T: int, res: ReservationTable) -> list[int]:
        """Plan components in transit that have no plan, in order; returns those still parked."""
        left = []
        for comp in comps:
            if not self._plan_transit(comp, T, res):
                left.append(comp)
        return left

    def _replan_all(self, T: int, res: ReservationTable) -> None:
        """Drop every plan of a component in transit and plan them all again, oldest first."""
        sim = self.sim
        transit = [c for c in range(sim.site.n_components) if sim.state.status[c] == _IN_TRANSIT]
        for c in transit:
            self.plans.pop(c, None)
        res.clear()
        res.update(self._reservations(T))
        order = sorted(transit, key=lambda c: self._seq.get(c, 0))
        for _ in range(3):
            left = self._plan_parked(order, T, res)
            if not left or len(left) == len(order):
                break
            order = left

    def _repair(self, T: int, res: ReservationTable, new: set[int]) -> None:
        """Replan the older plans whose path now crosses a target pose that may become ready
        (new goals can make a target ready during the path); keep the old plan if none."""
        sim = self.sim
        for comp, plan in list(self.plans.items()):
            if comp in new or plan.claim or sim.state.status[comp] != _IN_TRANSIT:
                continue
            rel = self._rel(comp)
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
                res.clear()
                res.update(saved)
                self.plans[comp] = plan

    def _assign(
        self, idle: list[int], candidates: list[int], T: int, res: ReservationTable
    ) -> dict[int, int]:
        """Give idle cranes ready components, cheapest first; returns crane -> component."""
        sim = self.sim
        taken = self._taken_targets()
        pairs = []
        for comp in candidates:
            pick = sim.state.pickup[comp]
            rel = tuple(j - pick[0] for j in pick)
            here = sim.site.cell(pick[0])
            for t in sim.ready_targets(comp):
                if t in taken:
                    continue
                goal = self._goal(rel, t)
                if goal is not None:
                    pairs.append((manhattan(here, sim.site.cell(goal)), comp, t, goal, rel))
        if self.rank == "list":
            pairs.sort(key=lambda p: (self._list_rank[p[1]], p[0], p[2]))
        else:
            pairs.sort(key=lambda p: p[:3])
        claims: dict[int, int] = {}
        used_c: set[int] = set()
        used_t: set[int] = set()
        idle = list(idle)
        searches = 0
        for _, comp, t, goal, rel in pairs:
            if not idle or searches >= self.max_searches:
                break
            if comp in used_c or t in used_t:
                continue
            pick = sim.state.pickup[comp]
            if res.conflict(pick, T, T + 1, comp):
                continue  # the pick-up pose is not free in the claim step
            stops = self._stops(comp, rel, t)
            start = pick[0]
            if start in stops:
                continue  # it would arrive at another target on being lifted
            # Under crane reach: the first idle crane whose zone holds the pick-up pose and t.
            crane = next((k for k in idle if _carries(sim, k, comp, t)), None)
            if crane is None:
                continue
            searches += 1
            path = self._search(comp, rel, start, T + 1, goal, stops, res, crane)
            if path is None:
                continue
            idle.remove(crane)
            plan = Plan(comp, crane, t, T + 1, path, claim=True)
            self._new_plan(plan)
            self._reserve_plan(res, plan, T)
            claims[crane] = comp
            used_c.add(comp)
            used_t.add(t)
            self.stats["claims"] += 1
        return claims


def _carries(sim: Simulator, crane: int, comp: int, target: int) -> bool:
    """Crane reach: the crane's zone holds the component's pick-up pose and the target."""
    site = sim.site
    return site.reaches(crane, sim.state.pickup[comp]) and site.reaches(
        crane, site.target_cells[target]
    )
