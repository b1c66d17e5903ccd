"""The carrier: carries assigned (component, target) tasks along reserved space-time paths.

The execution half of prioritized planning, as a library component. A task is started with
``try_start(crane, comp, target)``: a collision-free path (space-time A*, see
``multicrane.tasks.reservations``) is searched from the component's pick-up pose to the target
against the paths already reserved; on success the path is reserved and the crane is busy
until the component is assembled. ``actions(T)`` then turns the plans into the simulator's
motion actions for step ``T + 1``: claim ``8 + i``, moves ``0..5``, wait ``6``, assemble
``7``. Which task a crane takes is not its business (``policies.prioritized`` and the
task-level environment, ``multicrane.tasks.book``, decide that).

One decision round at simulator time ``T``:

    carrier.begin(T)                        # check the plans against the site; repair them
    carrier.try_start(crane, comp, target)  # any number of new tasks (claimed in step T + 1)
    joint = carrier.actions(T)              # one motion action per crane

**Reach.** A crane carries a component only inside its zone (``Site.reach``): every pose of
the path, the pick-up pose and the target must lie in it (a search reads where the shape
lies wholly in the zone: ``ShapeCache.reach``, ``fits_everywhere(zone, shape)``). Without
reach every crane reaches everywhere.

**Checks and repairs** (``begin``). Each round checks that every component is where its
plan says. If one is not (an arrival the plan did not foresee, a claim that failed; neither
was seen on the shipped scenarios), every plan is dropped and all components in transit are
planned again, oldest first, in up to three passes. A component in transit with no plan
(after a failed search) holds its cells for ever until it gets one; ``begin`` then returns
False and no new task may start. When new goals make a target able to become ready while an
older plan's path crosses its pose, that plan is replanned (the old one is kept if no new
one is found), so that the component does not arrive there by accident. The searches, replans
and repairs themselves are ``multicrane.tasks.carrier_planning``'s.
"""

from __future__ import annotations

import numpy as np

from multicrane.core.codes import ASSEMBLE, CLAIM_BASE, WAIT, Status
from multicrane.sim.simulator import NOBODY, Simulator
from multicrane.tasks.carrier_planning import CarrierPlanning
from multicrane.tasks.goal_poses import GoalPoses
from multicrane.tasks.reservation_arrays import ReservationArrays
from multicrane.tasks.reservations import Plan, stop_poses
from multicrane.tasks.search_memo import SearchMemo
from multicrane.tasks.shape_cache import ShapeCache

_INITIAL, _IN_TRANSIT, _ARRIVED, _ASSEMBLED = (int(s) for s in Status)

STAT_NAMES = ("searches", "failed", "expansions", "claims", "replans", "repairs", "fallbacks")


class Carrier(CarrierPlanning):
    """Plans, the reservation table and the motion actions of the cranes' tasks.

    ``slack``: how many steps past the shortest path length a search may run (waiting for
    other components); ``max_expansions``: A* states expanded per search at most. ``stats``
    counts searches, failures, expansions, claims, full replans, path repairs and fallbacks
    (a planned action the mask did not allow: the crane waits and everything is replanned).
    """

    def __init__(self, sim: Simulator, slack: int = 40, max_expansions: int = 20000):
        self.sim = sim
        self.slack = slack
        self.max_expansions = max_expansions
        self.stats = dict.fromkeys(STAT_NAMES, 0)
        self._move_of = {d: m for m, d in enumerate(sim.site.move_delta)}
        self.goals = GoalPoses(sim.site)  # the goal pose per (shape, target)
        self.shapes = ShapeCache(sim.site)  # base, reach and distance oracles of the searches
        self._pickups: list | None = None  # the pick-up poses ``_distances`` belong to
        self._distances = np.zeros((0, 0), dtype=np.int64)
        self.reset()

    def reset(self) -> None:
        """Forget every plan (at the start of an episode)."""
        self.plans: dict[int, Plan] = {}
        self._seq: dict[int, int] = {}  # comp -> plan creation number (the priority)
        self._counter = 0
        self._force_replan = False
        self._round: int | None = None
        self._res: ReservationArrays | None = None
        self._may_start = True
        self._claims: dict[int, int] = {}  # crane -> component claimed in step T + 1
        self._cached: tuple[int, list[int]] | None = None
        self.round_searches = 0
        self.memo: SearchMemo | None = None  # kept search answers (``share_searches``)

    def share_searches(self) -> SearchMemo | None:
        """The episode's kept search answers, for copies of this site to share
        (``multicrane.tasks.search_memo``; made on first asking; None on sites with events)."""
        if self.memo is None and self.sim.schedule is None:
            self.memo = SearchMemo(self.sim.state.pickup)
        return self.memo

    # -- queries -------------------------------------------------------------------------------

    def busy(self, crane: int) -> bool:
        """The crane holds a component, assembles, or claims one in the coming step."""
        st = self.sim.state
        return (st.held[crane] != NOBODY or bool(st.assembling[crane])
                or bool(st.pass_over[crane]) or crane in self._claims)  # fmt: skip

    def time_left(self, crane: int) -> int:
        """Estimated steps until the crane is idle: the path left plus the assembly."""
        sim = self.sim
        st = sim.state
        steps = sim.scenario.assembly_steps
        if st.assembling[crane]:
            return int(st.assembling[crane])
        comp = st.held[crane]
        if comp == NOBODY:
            comp = self._claims.get(crane, NOBODY)
            if comp == NOBODY:
                return 0
        if st.status[comp] == _ARRIVED:
            return steps
        plan = self.plans.get(comp)
        T = st.step_count
        if plan is None:
            return steps + 1
        return max(plan.arrival - T, 1) + steps

    def pair_distances(self) -> np.ndarray:
        """``GoalPoses.pair_distances`` of the episode's pick-up poses, computed once."""
        pickup = self.sim.state.pickup
        if pickup is not self._pickups:
            self._pickups, self._distances = pickup, self.goals.pair_distances(pickup)
        return self._distances

    def may_start(self, T: int) -> bool:
        """New tasks may start in this round (no component is stranded without a plan)."""
        self.begin(T)
        return self._may_start

    def reaches_pair(self, crane: int, comp: int, target: int) -> bool:
        """The crane's zone holds the component's pick-up pose and the target (static)."""
        reaches, pick = self.sim.site.reaches, self.sim.state.pickup[comp]
        return reaches(crane, pick) and reaches(crane, self.sim.site.target_cells[target])

    # -- the round -----------------------------------------------------------------------------

    def begin(self, T: int) -> None:
        """Start the decision round at time ``T`` (once per ``T``; later calls do nothing)."""
        if self._round == T:
            return
        if self._round is not None and self._round > T:
            self.reset()
        self._round = T
        self._res = None
        self._claims = {}
        self._cached = None
        self.round_searches = 0
        sim = self.sim
        diverged = self._sync(T) or self._force_replan
        self._force_replan = False
        status = sim.views.status
        # In transit = held by a crane (tests/sim/test_invariants.py); in index order.
        transit = sorted(c for c in sim.state.held if c != NOBODY and status[c] == _IN_TRANSIT)
        unplanned = [c for c in transit if c not in self.plans]
        if diverged or unplanned:
            res = self._table(T)
            if diverged:
                self.stats["replans"] += 1
                self._replan_all(T, res)
            elif unplanned:
                self._plan_parked(unplanned, T, res)
        self._may_start = all(c in self.plans for c in transit)

    def _table(self, T: int) -> ReservationArrays:
        if self._res is None:
            self._res = self._fresh_table(T)
        return self._res

    def _fresh_table(self, T: int) -> ReservationArrays:
        """The reservations of every plan from ``T`` on (a hook: events add closed cells)."""
        return ReservationArrays.of_plans(self.sim, self.plans, T)

    def try_start(self, crane: int, comp: int, target: int) -> bool:
        """Plan ``comp`` from its pick-up pose to ``target`` for ``crane``, claimed in step
        ``T + 1``; on success reserve the path and return True. Counts a search in
        ``round_searches`` only when the A* search ran (the cheap checks failing first)."""
        sim = self.sim
        T = sim.state.step_count
        self.begin(T)
        if not self._may_start or crane in self._claims or comp in self.plans:
            return False
        if not self.reaches_pair(crane, comp, target):
            return False
        pick = sim.state.pickup[comp]
        rel = tuple(j - pick[0] for j in pick)
        goal = self.goals[rel, target]
        if goal is None:
            return False
        res = self._table(T)
        if res.conflict(pick, T, T + 1, comp):
            return False  # the pick-up pose is not free in the claim step
        stops = self._stops(comp, rel, target)
        start = pick[0]
        if start in stops:
            return False  # it would arrive at another target on being lifted
        self.round_searches += 1
        path = self._search(comp, rel, start, T + 1, goal, stops, res, crane)
        if path is None:
            return False
        plan = Plan(comp, crane, target, T + 1, path, claim=True)
        self._new_plan(plan)
        res.reserve_plan(plan, rel, T)
        self._claims[crane] = comp
        self.stats["claims"] += 1
        return True

    def cancel(self, crane: int) -> None:
        """Undo this round's ``try_start`` of ``crane`` (nothing was claimed yet)."""
        comp = self._claims.pop(crane, None)
        if comp is None:
            return
        del self.plans[comp]
        self.stats["claims"] -= 1
        if self._res is not None:
            self._res.release(comp)

    def actions(self, T: int, masks=None) -> list[int]:
        """One motion action per crane for step ``T + 1``. Ends the round's new starts: older
        plans crossing a new goal's stop poses are repaired first. ``masks`` (optional, one
        row per crane): a planned action outside it becomes wait and forces a full replan."""
        self.begin(T)
        if self._cached is not None and self._cached[0] == T:
            return list(self._cached[1])
        if self._claims:
            self._repair(T, self._table(T), set(self._claims.values()))
        joint = self._planned(T)
        for crane, a in enumerate(joint):
            if masks is not None and not masks[crane][a]:
                self.stats["fallbacks"] += 1
                self._force_replan = True
                joint[crane] = WAIT
        self._cached = (T, joint)
        return list(joint)

    def cranes_down(self) -> frozenset[int] | tuple:
        return ()  # none without site events (``EventCarrier``)

    def crane_up(self, crane: int) -> bool:
        return crane not in self.cranes_down()

    def _planned(self, T: int) -> list[int]:
        """Each crane's action by the plans: wait while it assembles, is passed over or is
        down; its claim; assemble once arrived; its plan's move (wait without a plan)."""
        st, status, plans, claims = self.sim.state, self.sim.views.status, self.plans, self._claims
        down, joint = self.cranes_down(), []
        for crane, comp in enumerate(st.held):
            if st.assembling[crane] or st.pass_over[crane] or crane in down:
                a = WAIT
            elif comp == NOBODY:
                a = CLAIM_BASE + claims[crane] if crane in claims else WAIT
            elif status[comp] == _ARRIVED:
                a = ASSEMBLE
            else:
                plan = plans.get(comp)
                d = 0 if plan is None else plan.move_at(T)
                a = WAIT if d == 0 else self._move_of[d]
            joint.append(a)
        return joint

    # -- bookkeeping -------------------------------------------------------------------------

    def _sync(self, T: int) -> bool:
        """Drop finished plans; True when some component is not where its plan says."""
        sim = self.sim
        status = sim.views.status
        diverged = False
        for comp, plan in list(self.plans.items()):
            s = status[comp]
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
                at_goal = sim.state.cells[comp][0] == plan.positions[-1] and plan.arrival <= T
                if sim.state.filled[comp] != plan.target or not at_goal:
                    diverged = True
                del self.plans[comp]
        return diverged

    def _new_plan(self, plan: Plan) -> None:
        self.plans[plan.comp] = plan
        if plan.comp not in self._seq:
            self._counter += 1
            self._seq[plan.comp] = self._counter

    def _stops(self, comp: int, rel: tuple[int, ...], target: int) -> set[int]:
        """Poses of other compatible targets that are or may become ready during a path."""
        planned = {p.target for c, p in self.plans.items() if c != comp}
        return stop_poses(self.sim, comp, rel, target, planned, self.goals)

    def taken_targets(self) -> set[int]:
        """The targets of every plan."""
        return {p.target for p in self.plans.values()}
