"""Potential-based shaping of the learner's reward, both modes (Ng, Harada & Russell, 1999).

The team reward pays only on assembly, and random cranes hardly ever carry a component to
its target before the over-limit cost (-2 per step past 15 moves) sets in; PPO then learns
to wait forever (-1 per step, the best return random exploration ever shows it). Adding
``F = w * (gamma * phi(s') - phi(s))`` with

    phi(s) = - sum over unassembled components of the Manhattan distance (cells) from the
             component's position (its pick-up pose while in the yard) to the nearest pose
             where it would fill a free compatible target,

rewards every move towards a target and leaves the optimal policies of the discounted
problem unchanged (the shaping terms telescope). ``phi`` is 0 at the end of an episode.
Claiming does not change ``phi`` (a claimed component starts at its pick-up pose). The
environment's own reward, returns and statistics are untouched: only the reward the
learner sees changes.

Paper mode has two options (``TrainConfig.potential`` / ``shaping_gamma``): ``PathPotential``
counts shortest collision-free path lengths instead of Manhattan distances, and the discount
in ``F`` may be set apart from the learner's (1.0 gives ``w * (phi(s') - phi(s))``: no longer
policy-invariant under a learner discount below 1, but without the constant part
``(1 - gamma) * (-phi)`` that otherwise pays a learner for staying far from every target).

The multi-agent vector environment (``multicrane.training.vec_env.CraneVecEnv``) adds the
term itself; ``ShapedPaperEnv`` adds it to the single-agent benchmark environment
(``multicrane.envs.paper_env.PaperAssemblyEnv``), whose simulator has one crane.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np

from multicrane.core.codes import Status
from multicrane.sim.grid_search import breadth_first, fits_everywhere
from multicrane.sim.shortest_paths import current_cells, goal_positions
from multicrane.sim.simulator import FREE, NOBODY, Simulator

_ASSEMBLED = int(Status.ASSEMBLED)
_ARRIVED = int(Status.ARRIVED)
_INITIAL = int(Status.INITIAL)
_IN_TRANSIT = int(Status.IN_TRANSIT)


class DistancePotential:
    """``phi`` of the module doc for one simulator; call ``reset()`` after the env's reset.

    Kept incrementally: each component's distance is cached and measured again only when
    the component moved or changed status, or one of its compatible targets was filled or
    freed (a step moves at most one component per crane), and the sum is kept as a running
    total; which components changed is found by whole-array comparisons with the last call.
    The value equals the from-scratch sum (``potential_from_scratch``;
    tests/training/test_shaping.py).
    """

    def __init__(self, sim: Simulator):
        self.sim = sim
        self._goals: dict[int, list[tuple[int, int, int, int]]] = {}
        users: list[list[int]] = [[] for _ in range(sim.site.n_components)]
        for c, targets in enumerate(sim.site.compatible):
            for t in targets:
                users[t].append(c)
        self._users = users  # per target: the components that could fill it
        self.reset()

    def reset(self) -> None:
        self._goals.clear()  # the layout (pick-up poses) may change between episodes
        self._seen_state = self._seen_pickup = None  # what the caches were measured on
        self._part: list[int] = []  # per component: its term of the sum
        self._total = 0

    def _goal_table(self, comp: int) -> list[tuple[int, int, int, int]]:
        """Per goal pose of the component: (its target, its anchor cell's x, y, z)."""
        table = self._goals.get(comp)
        if table is None:
            sim = self.sim
            table = [
                (t, *sim.site.cell(g))
                for t in sim.site.compatible[comp]
                for g in goal_positions(sim, comp, [t])
            ]
            self._goals[comp] = table
        return table

    def _distance(self, comp: int, here: int, filled_by: list[int]) -> int:
        """Cells from ``here`` to the nearest goal pose of a free compatible target (0: none).
        Plain Python: a component has a few dozen goal poses, too few for numpy to pay."""
        x, y, z = self.sim.site.cell(here)
        best = None
        for t, gx, gy, gz in self._goal_table(comp):
            if filled_by[t] != NOBODY:
                continue
            d = abs(gx - x) + abs(gy - y) + abs(gz - z)
            if best is None or d < best:
                best = d
        return best or 0

    def __call__(self) -> float:
        sim = self.sim
        st = sim.state
        # What a component's distance depends on: its status and moves (every move counts
        # one; a claim changes the status), the pick-up poses, and the filled targets.
        if st is not self._seen_state or st.pickup is not self._seen_pickup:
            self._goals.clear()
            self._seen_state, self._seen_pickup = st, st.pickup
            self._part = [0] * sim.site.n_components
            self._total = 0
            stale = set(range(sim.site.n_components))
        else:
            moved = (st.status != self._seen_status) | (st.moves != self._seen_moves)
            stale = set(moved.nonzero()[0].tolist())
            refilled = (st.filled_by != self._seen_filled).nonzero()[0].tolist()
            for t in refilled:  # a nearest free target was taken (or freed by a restore)
                stale.update(self._users[t])
        if stale:
            self._seen_status = st.status.copy()
            self._seen_moves = st.moves.copy()
            self._seen_filled = st.filled_by.copy()
            part = self._part
            status, prebuilt, filled_by = st.status, st.prebuilt, st.filled_by.tolist()
            for comp in stale:
                s = int(status[comp])
                if s in (_ASSEMBLED, _ARRIVED) or prebuilt[comp]:
                    new = 0
                else:  # measured from the pick-up pose while in the yard
                    here = st.pickup[comp][0] if s == _INITIAL else st.cells[comp][0]
                    new = self._distance(comp, here, filled_by)
                self._total += new - part[comp]
                part[comp] = new
        return -float(self._total)


class ShapedPaperEnv(gym.Wrapper):
    """The paper environment with ``w * (gamma * phi(s') - phi(s))`` added to its reward.

    For the learner's copies only: wrap it outside ``Monitor`` so that the episode returns
    and statistics stay the paper's. ``info["paper_reward"]`` keeps the unshaped reward.
    ``phi(s')`` is 0 when the episode terminates (every component has arrived; the formula
    gives 0 then too) and the state's own value at truncation, where the learner bootstraps.
    """

    def __init__(self, env: gym.Env, weight: float, gamma: float, potential: str = "distance"):
        super().__init__(env)
        if not weight >= 0:
            raise ValueError(f"shaping weight must be >= 0, got {weight!r}")
        if not 0 <= gamma <= 1:
            raise ValueError(f"shaping gamma must be in [0, 1], got {gamma!r}")
        kinds = {"distance": DistancePotential, "path": PathPotential}
        if potential not in kinds:
            raise ValueError(f"potential={potential!r}: one of {', '.join(kinds)}")
        self.weight, self.gamma = float(weight), float(gamma)
        self.potential = kinds[potential](env.unwrapped.sim)
        self.phi = 0.0  # phi of the current state

    def reset(self, **kwargs):
        obs, info = self.env.reset(**kwargs)
        self.potential.reset()
        self.phi = self.potential()
        return obs, info

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        phi = 0.0 if terminated else self.potential()
        info["paper_reward"] = reward
        shaped = reward + self.weight * (self.gamma * phi - self.phi)
        self.phi = phi
        return obs, shaped, terminated, truncated, info


def potential_from_scratch(sim: Simulator) -> float:
    """``phi`` computed directly from the module doc's formula (the reference for tests)."""
    total = 0
    for comp in range(sim.site.n_components):
        status = int(sim.state.status[comp])
        if status in (_ASSEMBLED, _ARRIVED) or sim.state.prebuilt[comp]:
            continue
        x, y, z = sim.site.cell(current_cells(sim, comp)[0])
        best = None
        for t in sim.site.compatible[comp]:
            if sim.state.filled_by[t] != NOBODY:
                continue
            for g in goal_positions(sim, comp, [t]):
                gx, gy, gz = sim.site.cell(g)
                d = abs(gx - x) + abs(gy - y) + abs(gz - z)
                if best is None or d < best:
                    best = d
        total += best or 0
    return -float(total)


class PathPotential:
    """``phi`` with path lengths instead of Manhattan distances (``potential="path"``).

    A component in transit counts the moves of a shortest collision-free path
    (``multicrane.sim.shortest_paths.distance_field``) from where it is to the nearest goal pose of
    a free
    compatible target, with every component not in transit (and the obstacles) fixed; a
    component in the yard counts the same from its pick-up pose, measured once at reset.
    Unlike the Manhattan distance this has no local minimum in front of an obstacle or under
    a beam's supports, so moving down it always leads to a target. A field is measured again
    only when a component changes status or a target is filled.
    """

    def __init__(self, sim: Simulator):
        self.sim = sim
        self.reset()

    def reset(self) -> None:
        self._yard: list[int] | None = None  # per component: its distance at reset
        self._fields: dict[int, tuple[bytes, object]] = {}
        self._seen_pickup = None

    def _distance(self, comp: int, field) -> int:
        here = current_cells(self.sim, comp)[0]
        d = int(field[here])
        if d >= 0:
            return d
        x, y, z = self.sim.site.cell(here)  # nowhere to go now: fall back to Manhattan
        return min(
            (abs(gx - x) + abs(gy - y) + abs(gz - z)
             for gx, gy, gz in (self.sim.site.cell(g) for g in self._goals(comp))),
            default=0,
        )  # fmt: skip

    def _goals(self, comp: int) -> list[int]:
        st = self.sim.state
        free = [t for t in self.sim.site.compatible[comp] if st.filled_by[t] == NOBODY]
        return goal_positions(self.sim, comp, free)

    def _field(self, comp: int, key: bytes):
        cached = self._fields.get(comp)
        if cached is not None and cached[0] == key:
            return cached[1]
        sim, st = self.sim, self.sim.state
        shape = current_cells(sim, comp)
        moving = [c + 1 for c in (st.status == _IN_TRANSIT).nonzero()[0].tolist()]
        free = (st.occ == FREE) | np.isin(st.occ, [comp + 1, *moving])
        ok = fits_everywhere(free, [j - shape[0] for j in shape])
        field = breadth_first(ok, self._goals(comp), sim.site.move_delta)
        self._fields[comp] = (key, field)
        return field

    def __call__(self) -> float:
        sim, st = self.sim, self.sim.state
        key = st.status.tobytes() + st.filled_by.tobytes()
        if self._yard is None or st.pickup is not self._seen_pickup:
            self._seen_pickup = st.pickup
            self._fields.clear()
            self._yard = [
                self._distance(c, self._field(c, key)) if st.status[c] == _INITIAL else 0
                for c in range(sim.site.n_components)
            ]
        total = 0
        for comp in range(sim.site.n_components):
            s = int(st.status[comp])
            if s in (_ASSEMBLED, _ARRIVED) or st.prebuilt[comp]:
                continue
            if s == _INITIAL:
                total += self._yard[comp]
            else:
                total += self._distance(comp, self._field(comp, key))
        return -float(total)
