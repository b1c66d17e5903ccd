"""Invariants of the simulator and the environment, checked after every step of long play.

Random masked play (a uniformly random legal action per crane) runs on every shipped scenario:
10,000 joint steps with the scenario's own cranes, 3,000 with three cranes, and 5,000 in the
paper's automatic mode with one crane on the e?s? scenarios (these are the ``-m long`` sizes;
the default suite plays 1,000, 500 and 500 steps, and 300 guided steps instead of 1,200).
Random play seldom builds anything, so a guided variant (legal actions biased towards the
held component's free targets) also runs on every scenario and must assemble components.
After every step the checker asserts, with numpy on the whole grid:

- the occupancy grid agrees with the components (each component's cells hold its value, no
  cell holds two components, no stray component cells), the walls and obstacles never change,
  every component is a straight axis-parallel line of its length (a panel: a full rectangle
  of its target's sides) inside the site;
- statuses never go back and change only along the state machine's edges; yard, arrived and
  assembled components never move; carried components move by at most one cell a step;
- the bookkeeping agrees: placed count, holders and held components, filled targets, supports;
- masks have the declared length, allow wait, and claims agree with a from-scratch judgement;
- rewards are finite, equal for all cranes, split into per-crane terms that add up, and follow
  the spec card; terminations exactly when all is assembled, truncations exactly at the limit;
- observations are float32 in [0, 1] and, every so many steps and at every reset, equal to
  observations built from scratch by a fresh ``Observer`` (the real one updates
  incrementally); events belong to the crane and step that reported them.
"""

from __future__ import annotations

import math
from collections import Counter

import numpy as np
import pytest
from conftest import SCENARIOS, random_masked_actions, reach_skip, readable_env, sizes

from multicrane.core.codes import ASSEMBLE, CLAIM_BASE, N_MOVES, WAIT, EventType, Status
from multicrane.envs.observation import Observer
from multicrane.sim.geometry import extent
from multicrane.sim.simulator import FREE, NOBODY, WALL

INITIAL, IN_TRANSIT, ARRIVED, ASSEMBLED = (int(s) for s in Status)
PAPER_SCENARIOS = [s for s in SCENARIOS if len(s) == 4 and s[0] == "e" and s[2] == "s"]

# The state machine's edges that one step may take (a component may take several edges in
# one step: a lift can end on a target, and automatic mode assembles on arrival).
EDGES_MANUAL = {(INITIAL, IN_TRANSIT), (INITIAL, ARRIVED), (IN_TRANSIT, ARRIVED)}
EDGES_MANUAL |= {(ARRIVED, ASSEMBLED)}
EDGES_AUTO = {(INITIAL, IN_TRANSIT), (INITIAL, ASSEMBLED), (IN_TRANSIT, ASSEMBLED)}
# Events that masked actions can cause only when several cranes act in one step.
RACE_EVENTS = {EventType.BLOCKED, EventType.LIFT_BLOCKED, EventType.CLAIM_CONFLICT}


def _table(values, size=8):
    """A boolean lookup table: cheaper than np.isin on every step."""
    table = np.zeros(size, dtype=bool)
    table[list(values)] = True
    return table


VALID_STATUS = _table((INITIAL, IN_TRANSIT, ARRIVED, ASSEMBLED))
HOLDABLE_MANUAL = _table((IN_TRANSIT, ARRIVED))
HOLDABLE_AUTO = _table((INITIAL, IN_TRANSIT))


def _edge_table(edges):
    return _table((a * 8 + b for a, b in edges), size=64)


class Checker:
    """Checks one environment after reset and after every step."""

    def __init__(self, env):
        self.env = env
        sim = env.sim
        self.sim = sim
        self.auto = sim.auto
        self.C = sim.site.n_components
        self.n = sim.n_cranes
        self.X, self.Y, self.H = sim.scenario.size
        self.shape = sim.site.shape
        self.sx = self.shape[1] * self.shape[2]
        self.sy = self.shape[2]
        self.wall = sim.site.static == WALL
        self.lengths = np.array(sim.site.length, dtype=np.int64)
        self.total = int(self.lengths.sum())
        self.starts = np.concatenate([[0], np.cumsum(self.lengths)[:-1]]).astype(np.int64)
        self.owner = np.repeat(np.arange(1, self.C + 1), self.lengths)
        # A straight component spans (0, 0, length - 1); a panel its target's two sides (it
        # lies flat or stands in the target's orientation, both of those sides).
        self.expected_spans = np.array(
            [sorted(n - 1 for n in extent(*c.target)) for c in sim.scenario.components],
            dtype=np.int64,
        ).reshape(self.C, 3)
        self.edges = _edge_table(EDGES_AUTO if self.auto else EDGES_MANUAL)
        self.shifts = {0, *sim.site.move_delta}
        self.holdable = HOLDABLE_AUTO if self.auto else HOLDABLE_MANUAL
        self.n_actions = sim.site.n_actions
        self.obs_size = env.observation_layout.size
        self.spec = sim.scenario.reward
        self.events = Counter()
        self.steps = 0
        self.episodes = 0
        self.terminated = 0

    # -- helpers ------------------------------------------------------------------------------

    def _cells(self) -> np.ndarray:
        sim = self.sim
        assert [len(c) for c in sim.state.cells] == sim.site.length, (
            "a component changed its length"
        )
        return np.fromiter(
            (j for cells in sim.state.cells for j in cells), dtype=np.int64, count=self.total
        )

    def _decode(self, idx: np.ndarray) -> np.ndarray:
        px, rest = np.divmod(idx, self.sx)
        py, z = np.divmod(rest, self.sy)
        return np.stack([px - 1, py - 1, z], axis=1)

    # -- the checks ---------------------------------------------------------------------------

    def reset(self, obs, infos):
        sim = self.sim
        self.episodes += 1
        idx = self._cells()
        # The vectorised decoding is sim.site.cell's.
        coords = self._decode(idx)
        assert [tuple(int(v) for v in c) for c in coords] == [sim.site.cell(int(j)) for j in idx]
        status = sim.state.status
        assert set(np.unique(status).tolist()) <= {INITIAL, ASSEMBLED}
        assert np.array_equal(status == ASSEMBLED, sim.state.prebuilt)
        assert sim.state.step_count == 0
        assert sim.state.n_assembled == sim.state.n_prebuilt == int(sim.state.prebuilt.sum())
        assert not any(sim.state.assembling)
        if not self.auto:
            assert all(c == NOBODY for c in sim.state.held)
        assert self.env.agents == self.env.possible_agents
        for agent in self.env.possible_agents:
            assert infos[agent]["events"] == ()
            assert infos[agent]["reward_term"] == 0.0
        self._check_state(idx)
        self._check_masks(obs, infos)
        self._check_observations(obs)
        self.prev_status = status.copy()
        self.prev_idx = idx
        self.prev_filled = sim.state.filled.copy()

    def step(self, actions, obs, rewards, terminations, truncations, infos):
        sim = self.sim
        self.steps += 1
        idx = self._cells()
        self._check_state(idx)
        self._check_motion(idx)
        self._check_masks(obs, infos)
        self._check_observations(obs)
        self._check_events(actions, infos)
        self._check_outcome(rewards, terminations, truncations, infos)
        self.prev_status = sim.state.status.copy()
        self.prev_idx = idx
        self.prev_filled = sim.state.filled.copy()

    def _check_state(self, idx):
        sim = self.sim
        occ = sim.state.occ
        C = self.C
        # Occupancy agrees with the components; no two components share a cell.
        assert np.array_equal(occ[idx], self.owner), "a component's cells do not hold its value"
        ordered = np.sort(idx)
        assert (ordered[1:] != ordered[:-1]).all(), "two components (or one twice) in a cell"
        assert np.count_nonzero(occ > 0) == self.total, "stray component values in the grid"
        assert occ.min() >= WALL and occ.max() <= C
        # Walls, ground, sky and obstacles never change; nothing enters them.
        assert np.array_equal(occ == WALL, self.wall), "the wall set changed"
        # Straight, axis-parallel lines of their length (panels: full rectangles of their
        # target's sides, as many cells as the box holds), inside the site.
        coords = self._decode(idx)
        assert coords[:, 0].min() >= 0 and coords[:, 0].max() < self.X
        assert coords[:, 1].min() >= 0 and coords[:, 1].max() < self.Y
        assert coords[:, 2].min() >= 1 and coords[:, 2].max() <= self.H
        lo = np.minimum.reduceat(coords, self.starts, axis=0)
        hi = np.maximum.reduceat(coords, self.starts, axis=0)
        spans = np.sort(hi - lo, axis=1)
        bad = np.flatnonzero((spans != self.expected_spans).any(axis=1))
        assert bad.size == 0, f"components {bad.tolist()} are not lines or panels of their shape"

        status = sim.state.status
        assert status.min() >= 0 and status.max() <= ASSEMBLED
        assert VALID_STATUS[status].all(), f"unknown status values {np.unique(status)}"
        assert sim.state.n_assembled == int(np.count_nonzero(status == ASSEMBLED))
        assert sim.done == (sim.state.n_assembled == C)
        assert sim.k == sim.state.n_assembled - sim.state.n_prebuilt
        # Cranes and holders.
        held = np.array(sim.state.held, dtype=np.int64)
        holder = sim.state.holder
        busy = held[held != NOBODY]
        assert np.unique(busy).size == busy.size, "one component held by two cranes"
        assert np.count_nonzero(holder != NOBODY) == busy.size
        for crane, comp in enumerate(sim.state.held):
            if comp != NOBODY:
                assert holder[comp] == crane, (crane, comp, holder[comp])
                if status[comp] in (IN_TRANSIT, ARRIVED):  # crane reach: inside its zone
                    assert sim.site.reaches(crane, sim.state.cells[comp]), (crane, comp)
        carried = holder != NOBODY
        holdable = self.holdable[status]
        if self.auto:
            assert holdable[carried].all(), "a carried component is placed"
            assert not np.any(status == ARRIVED), "automatic mode assembles on arrival"
            assert np.all(carried[status == IN_TRANSIT])
        else:
            assert np.array_equal(carried, holdable), "carried exactly when in transit/arrived"
        for crane in range(self.n):
            steps_left = sim.state.assembling[crane]
            assert 0 <= steps_left <= sim.scenario.assembly_steps
            if steps_left:
                assert not self.auto
                assert status[sim.state.held[crane]] == ARRIVED
        # Filled targets.
        filled, filled_by = sim.state.filled, sim.state.filled_by
        placed = status >= ARRIVED
        assert np.array_equal(filled >= 0, placed), "filled disagrees with the statuses"
        comps = np.flatnonzero(placed)
        assert np.array_equal(filled_by[filled[comps]], comps)
        assert np.count_nonzero(filled_by >= 0) == comps.size
        for c in comps.tolist():
            t = int(filled[c])
            assert t in sim.site.compatible[c]
            assert sim.site.target_cellset[t] == frozenset(sim.state.cells[c]), (
                f"{c} is not on target {t}"
            )
            for s in sim.site.target_supports[t]:
                f = int(filled_by[s])
                assert f >= 0 and status[f] == ASSEMBLED, f"target {t} stands on nothing"

    def _check_motion(self, idx):
        sim = self.sim
        prev, status = self.prev_status, sim.state.status
        assert np.all(status >= self.prev_status), "a status went backwards"
        changed = np.flatnonzero(status != prev)
        if changed.size:
            ok = self.edges[prev[changed].astype(np.int64) * 8 + status[changed]]
            bad = np.stack([prev[changed][~ok], status[changed][~ok]], axis=1).tolist()
            assert ok.all(), f"illegal status transitions (before, after): {bad}"
        delta = idx - self.prev_idx
        first = np.repeat(delta[self.starts], self.lengths)
        rigid = np.logical_and.reduceat(delta == first, self.starts)
        still = np.logical_and.reduceat(delta == 0, self.starts)
        # Yard components that stay in the yard, arrived and assembled ones never move.
        frozen = (prev >= ARRIVED) | ((prev == INITIAL) & (status == INITIAL))
        bad = np.flatnonzero(~still & frozen)
        assert bad.size == 0, f"components {bad.tolist()} moved but should be at rest"
        # A carried component moves rigidly by at most one cell.
        carried = np.flatnonzero(prev == IN_TRANSIT)
        if carried.size:
            assert rigid[carried].all(), "a carried component changed shape"
            assert set(delta[self.starts[carried]].tolist()) <= self.shifts, "a jump"
        # A lifted component appears at its pick-up pose (automatic mode: then one move).
        for c in np.flatnonzero((prev == INITIAL) & (status != INITIAL)).tolist():
            pickup = np.array(sim.state.pickup[c], dtype=np.int64)
            shift = np.array(sim.state.cells[c], dtype=np.int64) - pickup
            assert np.all(shift == shift[0]), f"{c} was lifted out of shape"
            allowed = self.shifts if self.auto else {0}
            assert int(shift[0]) in allowed, f"{c} was not lifted to its pick-up pose"
        # Filled targets stay filled by the same components.
        was = self.prev_filled >= 0
        assert np.array_equal(sim.state.filled[was], self.prev_filled[was])

    def _check_masks(self, obs, infos):
        sim = self.sim
        masks = self.env.action_masks()
        assert list(masks) == self.env.possible_agents
        claimable = None
        if not self.auto:
            claimable = np.zeros(self.C, dtype=np.int8)
            claimable[[c for c in range(self.C) if sim.claimable(c)]] = 1
            assert sim.claimable_components() == np.flatnonzero(claimable).tolist(), (
                "the incremental claim cache disagrees with a fresh judgement"
            )
        for i, agent in enumerate(self.env.possible_agents):
            m = masks[agent]
            assert m.dtype == np.int8 and m.shape == (self.n_actions,)
            assert np.array_equal(obs[agent]["action_mask"], m)
            assert np.array_equal(infos[agent]["action_mask"], m)
            assert ((m == 0) | (m == 1)).all()
            assert m[WAIT] == 1, "wait must always be allowed"
            assert m.any()
            comp = sim.state.held[i]
            if self.auto:
                assert not m[ASSEMBLE] and not m[CLAIM_BASE:].any()
            elif sim.state.assembling[i]:
                assert m.sum() == 1  # only wait while assembling
            elif comp == NOBODY:
                assert not m[:N_MOVES].any() and not m[ASSEMBLE]
                # Crane reach: a crane claims only what its zone allows (else every crane).
                reach = [int(sim.in_reach(i, c)) for c in range(self.C)]
                assert np.array_equal(m[CLAIM_BASE:], claimable & np.array(reach, np.int8))
            else:
                assert not m[CLAIM_BASE:].any()
                assert m[ASSEMBLE] == (sim.state.status[comp] == ARRIVED)
                if sim.state.status[comp] == ARRIVED:
                    assert not m[:N_MOVES].any()

    def _check_observations(self, obs):
        assert list(obs) == self.env.possible_agents
        for o in obs.values():
            v = o["observation"]
            assert v.dtype == np.float32 and v.shape == (self.obs_size,)
            assert v.min() >= 0.0 and v.max() <= 1.0, "observation outside [0, 1]"

    def check_fresh_observations(self, obs):
        """The incrementally updated observations equal ones built from scratch."""
        sim, env = self.sim, self.env
        spec = getattr(env.observer, "spec", None)  # the planes the environment observes
        fresh = Observer(sim) if spec is None else Observer(sim, spec)
        fresh.reset(env.step_limit)
        if self.auto:
            ready = [c for c in sim.state.held if c != NOBODY and sim.state.status[c] == INITIAL]
        else:
            ready = sim.claimable_components()
        fresh.update(set(), ready, full=True)
        for i, agent in enumerate(env.possible_agents):
            mine = obs[agent]["observation"]
            expected = fresh.observe(i)
            if not np.array_equal(mine, expected):
                diff = np.flatnonzero(mine != expected)
                parts = env.observation_layout.split(mine - expected)
                where = [k for k, v in parts.items() if np.any(v)]
                raise AssertionError(
                    f"step {sim.state.step_count}: {agent}'s observation differs from a fresh one "
                    f"at {diff.size} entries (in {where}), first {diff[:5].tolist()}"
                )

    def _check_events(self, actions, infos):
        sim = self.sim
        for i, agent in enumerate(self.env.possible_agents):
            for e in infos[agent]["events"]:
                assert e.crane == i and e.step == sim.state.step_count, e
                self.events[e.type.name] += 1
                if self.n == 1:
                    # One crane sending masked actions never hits a refusal.
                    assert e.type not in RACE_EVENTS | {EventType.ILLEGAL}, e
                elif e.type == EventType.ILLEGAL:
                    # Only a race can make a masked action illegal: an earlier crane filled
                    # the last free target a claimed beam could go to.
                    assert e.detail.startswith("claim"), e
                if self.auto:
                    assert e.type not in (EventType.CLAIMED, EventType.ASSEMBLY_STARTED), e
                else:
                    assert e.type not in (EventType.ASSIGNED, EventType.PASS_OVER), e

    def _check_outcome(self, rewards, terminations, truncations, infos):
        sim, env = self.sim, self.env
        agents = env.possible_agents
        assert list(rewards) == list(terminations) == list(truncations) == agents
        values = set(rewards.values())
        assert len(values) == 1, f"rewards differ between cranes: {rewards}"
        r = values.pop()
        assert math.isfinite(r)
        terms = [infos[a]["reward_term"] for a in agents]
        assert all(math.isfinite(t) for t in terms)
        assert math.isclose(sum(terms), r, rel_tol=1e-9, abs_tol=1e-9), (terms, r)
        # The spec card's reward.
        progress = sum(
            e.type in (EventType.ASSEMBLED, EventType.PASS_OVER)
            for a in agents
            for e in infos[a]["events"]
        )
        over = any(
            comp != NOBODY and sim.state.moves[comp] > sim.site.move_limit
            for comp in sim.state.held
        )
        if sim.done:
            expected = self.spec.completion
        elif progress:
            expected = float(progress * sim.state.n_assembled)
        elif over:
            expected = -self.spec.over_limit_cost
        else:
            expected = -self.spec.step_cost / (sim.k + 1)
        assert math.isclose(r, expected, rel_tol=1e-9, abs_tol=1e-12), (r, expected)
        # Termination and truncation.
        term, trunc = set(terminations.values()), set(truncations.values())
        assert len(term) == 1 and len(trunc) == 1
        term, trunc = term.pop(), trunc.pop()
        assert term == sim.done, "terminated exactly when every component is assembled"
        assert trunc == (not sim.done and sim.state.step_count >= env.step_limit)
        assert not (term and trunc)
        assert sim.state.step_count <= env.step_limit
        assert (env.agents == []) == (term or trunc)
        if term:
            self.terminated += 1


# ---------------------------------------------------------------------------------------------
# Play


def _guided_actions(env, obs, rng, greed=0.8):
    """Legal actions biased towards progress: assemble when possible, claim when idle, and
    mostly take the legal move that brings the held component nearest a free target."""
    sim = env.sim
    actions = {}
    for i, agent in enumerate(env.possible_agents):
        mask = obs[agent]["action_mask"]
        legal = np.flatnonzero(mask)
        if mask[ASSEMBLE]:
            actions[agent] = ASSEMBLE
            continue
        claims = legal[legal >= CLAIM_BASE]
        # Prefer components that have somewhere to go now: a column whose target is not yet
        # supported (a storey-2 column) may be claimed, but would be carried about for ever.
        going = [a for a in claims.tolist() if sim.ready_targets(a - CLAIM_BASE)]
        if going:
            claims = np.array(going)
        if claims.size:
            actions[agent] = int(claims[rng.integers(claims.size)])
            continue
        moves = legal[legal < N_MOVES]
        comp = sim.state.held[i]
        targets = sim.ready_targets(comp) if comp != NOBODY else []
        if moves.size and targets and rng.random() < greed:
            source = (
                sim.state.cells[comp]
                if sim.state.status[comp] == IN_TRANSIT
                else sim.state.pickup[comp]
            )
            here = np.sort(np.array(source, dtype=np.int64))
            goals = [np.sort(np.array(sim.site.target_cells[t], dtype=np.int64)) for t in targets]
            best, choice = None, []
            for m in moves.tolist():
                cells = here + sim.site.move_delta[m]
                d = min(_manhattan(sim, cells, g) for g in goals)
                if best is None or d < best:
                    best, choice = d, [m]
                elif d == best:
                    choice.append(m)
            actions[agent] = int(choice[rng.integers(len(choice))])
            continue
        actions[agent] = int(legal[rng.integers(legal.size)])
    return actions


def _manhattan(sim, a, b):
    sx = sim.site.shape[1] * sim.site.shape[2]
    sy = sim.site.shape[2]
    ax, ar = np.divmod(a, sx)
    ay, az = np.divmod(ar, sy)
    bx, br = np.divmod(b, sx)
    by, bz = np.divmod(br, sy)
    return int(np.abs(ax - bx).sum() + np.abs(ay - by).sum() + np.abs(az - bz).sum())


def play(name, steps, n_cranes=None, auto=False, seed=0, guided=False, fresh_every=100):
    """Play ``steps`` joint steps, checking every one; every ``fresh_every`` steps (and at
    every reset) the observations are also compared with ones built from scratch."""
    env = readable_env(name, n_cranes=n_cranes, auto=auto)
    rng = np.random.default_rng(seed)
    obs, infos = env.reset(seed=seed)
    checker = Checker(env)
    checker.reset(obs, infos)
    checker.check_fresh_observations(obs)
    for t in range(1, steps + 1):
        if guided:
            actions = _guided_actions(env, obs, rng)
        else:
            actions = random_masked_actions(obs, rng)
        obs, rewards, terminations, truncations, infos = env.step(actions)
        checker.step(actions, obs, rewards, terminations, truncations, infos)
        if t % fresh_every == 0 or not env.agents:
            checker.check_fresh_observations(obs)
        if not env.agents:
            obs, infos = env.reset()  # no seed: the episode generator continues
            checker.reset(obs, infos)
            checker.check_fresh_observations(obs)
    return checker


@pytest.mark.slow
@pytest.mark.parametrize("steps", sizes(1_000, 10_000))
@pytest.mark.parametrize("name", SCENARIOS)
def test_random_play_scenario_cranes(name, steps):
    checker = play(name, steps, seed=1)
    assert checker.steps == steps
    assert checker.events["LIFTED"] > 0


@pytest.mark.slow
@pytest.mark.parametrize("steps", sizes(500, 3_000))
@pytest.mark.parametrize("name", SCENARIOS)
def test_random_play_three_cranes(name, steps):
    checker = play(name, steps, n_cranes=3, seed=2)
    assert checker.steps == steps
    assert checker.events["LIFTED"] > 0


@pytest.mark.slow
@pytest.mark.parametrize("steps", sizes(500, 5_000))
@pytest.mark.parametrize("name", PAPER_SCENARIOS)
def test_random_play_automatic_mode(name, steps):
    checker = play(name, steps, n_cranes=1, auto=True, seed=3)
    assert checker.steps == steps
    assert checker.events["LIFTED"] > 0


GUIDED = [
    pytest.param(
        name,
        n,
        auto,
        id=f"{name}-{'auto' if auto else (n or 'own')}",
        marks=[pytest.mark.skip(reason=why)] if (why := reach_skip(name, 1 if auto else n)) else [],
    )
    for name in SCENARIOS
    for n, auto in ((None, False), (3, False), (1, True))
]


@pytest.mark.slow
@pytest.mark.parametrize("steps", sizes(300, 1_200))  # the first assembly: by step 42 at most
@pytest.mark.parametrize(("name", "n", "auto"), GUIDED)
def test_guided_play(name, n, auto, steps):
    checker = play(name, steps, n_cranes=n, auto=auto, seed=4, guided=True, fresh_every=10)
    assert checker.events["ARRIVED"] > 0
    assert checker.events["ASSEMBLED"] > 0


def test_guided_play_finishes_buildings():
    """The guided runs reach the terminal state, so its checks are exercised."""
    for name in ("e1s1", "e2s3", "e3s1"):
        for n, auto in ((None, False), (3, False), (1, True)):
            checker = play(name, 600, n_cranes=n, auto=auto, seed=5, guided=True, fresh_every=5)
            assert checker.terminated > 0, (name, n, auto)


def test_checker_catches_a_corrupted_grid():
    """The checks are not vacuous: a stray component cell or a lost wall is caught."""
    env = readable_env("e2s2")
    obs, infos = env.reset(seed=0)
    checker = Checker(env)
    checker.reset(obs, infos)
    free = int(np.flatnonzero(env.sim.state.occ == FREE)[0])
    env.sim.state.occ[free] = 1
    with pytest.raises(AssertionError):
        checker.reset(obs, infos)
    env.sim.state.occ[free] = FREE
    wall = int(np.flatnonzero(env.sim.state.occ == WALL)[0])
    env.sim.state.occ[wall] = FREE
    with pytest.raises(AssertionError):
        checker.reset(obs, infos)
    env.sim.state.occ[wall] = WALL
    checker.reset(obs, infos)
