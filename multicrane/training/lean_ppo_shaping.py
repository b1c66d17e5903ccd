"""The lean PPO's shaped reward: ``multicrane.training.shaping``'s potentials for B vector copies.

``ShapedCopies`` steps a ``PaperVectorEnv`` with the paper's reward plus ``w (g phi(s') -
phi(s))``, number for number the reward that ``ShapedPaperEnv`` gives the SB3 learners
(tests/training/test_lean_ppo_shaping.py compares them episode by episode): ``phi`` is
``DistancePotential`` (``"distance"``) or ``PathPotential`` (``"path"``), compiled here on the
copies' state arrays. ``phi(s')`` is 0 when an episode terminates and the final state's own
value when it is truncated (the learner bootstraps there); the copies reset in the same step,
so the step kernel below is ``paper_step.step_batch`` with the potential of each copy's last
state taken before its autoreset and the new episode's after it. Only the learner's reward
changes: the env's reward, returns and statistics stay the paper's.

The path potential keeps per copy what ``PathPotential`` caches: each yard component's path
length measured at reset, and the distance field of the component in transit (measured when
it is first seen in transit; in the paper mode nothing else moves until it arrives).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from multicrane.sim.site import Site
from multicrane.vector import paper_rules as rules
from multicrane.vector.compiled import kernel
from multicrane.vector.paper_reset import reset_copy
from multicrane.vector.paper_step import step_copy
from multicrane.vector.paper_vector_env import PaperVectorEnv

KINDS = ("distance", "path")
_PATH = 1  # KINDS.index("path")
_SAVED = ("phi", "yard", "field", "field_comp")  # what a checkpoint keeps


class Potentials(NamedTuple):
    """Per-copy potentials and the kernels' scratch (``C`` components, ``P`` grid cells)."""

    phi: np.ndarray  # (B,) float64: phi of each copy's present state
    yard: np.ndarray  # (B, C) int64: path potential: a yard component's length at reset
    field: np.ndarray  # (B, P) int32: path potential: the field of ``field_comp``
    field_comp: np.ndarray  # (B,) int64: the component whose field is held, -1 none
    shaped: np.ndarray  # (B,) float64: the step's shaped rewards
    coords: np.ndarray  # (P, 3) int64: each cell's (x, y, z), for Manhattan distances
    free: np.ndarray  # (P,) bool scratch: cells a component may enter
    ok: np.ndarray  # (P,) bool scratch: positions where it fits
    queue: np.ndarray  # (P,) int64 scratch: the breadth-first frontier
    rel: np.ndarray  # (L,) int64 scratch: a shape's sorted offsets
    sorted_cells: np.ndarray  # (L,) int64 scratch: a target's sorted cells


def allocate(envs: PaperVectorEnv) -> Potentials:
    """Zeroed potentials for the copies of ``envs``."""
    site = Site(envs.scenario)
    n, (C, L), P = envs.num_envs, envs.site.target_cells.shape, len(envs.site.static_occ)
    return Potentials(
        phi=np.zeros(n), yard=np.zeros((n, C), dtype=np.int64),
        field=np.full((n, P), -1, dtype=np.int32), field_comp=np.full(n, -1, dtype=np.int64),
        shaped=np.zeros(n), coords=np.array([site.cell(j) for j in range(P)], dtype=np.int64),
        free=np.zeros(P, dtype=bool), ok=np.zeros(P, dtype=bool),
        queue=np.zeros(P, dtype=np.int64), rel=np.zeros(L, dtype=np.int64),
        sorted_cells=np.zeros(L, dtype=np.int64),
    )  # fmt: skip


class ShapedCopies:
    """``envs`` stepped with the shaped reward (``weight``, discount ``gamma``, potential
    ``kind``); ``reset`` and ``step`` return what ``PaperVectorEnv`` writes in its buffers,
    and ``step`` the shaped rewards (``potentials.shaped``) beside the env's own."""

    def __init__(self, envs: PaperVectorEnv, weight: float, gamma: float, kind: str):
        if not weight >= 0:
            raise ValueError(f"shaping weight must be >= 0, got {weight!r}")
        if not 0 <= gamma <= 1:
            raise ValueError(f"shaping gamma must be in [0, 1], got {gamma!r}")
        if kind not in KINDS:
            raise ValueError(f"potential={kind!r}: one of {', '.join(KINDS)}")
        self.envs, self.weight, self.gamma = envs, float(weight), float(gamma)
        self.kind = KINDS.index(kind)
        self.potentials = allocate(envs)

    def reset(self, seed: int) -> None:
        """Reset the copies and measure every copy's potential."""
        self.envs.reset(seed=seed)
        envs = self.envs
        start_all(envs.site, envs.state, self.potentials, self.kind)

    def step(self, actions: np.ndarray) -> np.ndarray:
        """One step of every copy (autoresets included); returns the shaped rewards. The
        env's buffers hold its own outputs, ``final_obs`` included."""
        envs = self.envs
        bad, failed = shaped_step_batch(envs.site, envs.state, envs.buffers, actions,
                                        envs.mask_blocked_moves, self.potentials, self.kind,
                                        self.weight, self.gamma)  # fmt: skip
        if bad >= 0:
            raise ValueError(f"step(): copy {bad}: action must be 0..5, got {actions[bad]}")
        if failed >= 0:
            envs._no_start(failed)
        return self.potentials.shaped

    def get_state(self) -> dict[str, Any]:
        return {name: getattr(self.potentials, name).copy() for name in _SAVED}

    def set_state(self, saved: dict[str, Any]) -> None:
        for name in _SAVED:
            getattr(self.potentials, name)[...] = saved[name]


# -- the kernels -------------------------------------------------------------------------------


@kernel
def shaped_step_batch(site, st, buf, actions, mask_blocked, pot, kind, weight, gamma):
    """``step_batch`` with ``pot.shaped`` written: returns (first copy with an action outside
    0..5, first copy whose reset found no start), each -1 when none."""
    n = len(actions)
    for b in range(n):
        if actions[b] < 0 or actions[b] >= len(site.move_delta):
            return b, -1
    for b in range(n):
        ended = step_copy(site, st, buf, b, actions[b], mask_blocked)
        after = 0.0 if buf.terminated[b] else potential(site, st, pot, b, kind)
        pot.shaped[b] = buf.rewards[b] + weight * (gamma * after - pot.phi[b])
        if ended:
            for i in range(buf.obs.shape[1]):
                buf.final_obs[b, i] = buf.obs[b, i]
            if not reset_copy(site, st, buf, b, mask_blocked):
                return -1, b
            start_episode(site, st, pot, b, kind)
            after = potential(site, st, pot, b, kind)
        pot.phi[b] = after
    return -1, -1


@kernel
def start_all(site, st, pot, kind):
    """Every copy's potential at the start of its episode."""
    for b in range(len(pot.phi)):
        start_episode(site, st, pot, b, kind)
        pot.phi[b] = potential(site, st, pot, b, kind)


@kernel
def start_episode(site, st, pot, b, kind):
    """What the path potential measures once per episode: each yard component's length."""
    pot.field_comp[b] = -1
    if kind != _PATH:
        return
    for c in range(len(site.length)):
        pot.yard[b, c] = 0
        if st.status[b, c] == rules.INITIAL:
            measure_field(site, st, pot, b, c, st.pickup)
            pot.yard[b, c] = path_length(site, st, pot, b, c, st.pickup)
    pot.field_comp[b] = -1  # the field held is a yard component's, measured at reset


@kernel
def potential(site, st, pot, b, kind):
    """phi of copy ``b``: minus the summed distance of every unassembled component."""
    total = 0
    for c in range(len(site.length)):
        s = st.status[b, c]
        if s == rules.ASSEMBLED or s == rules.ARRIVED or site.prebuilt[c]:
            continue
        shape = st.pickup if s == rules.INITIAL else st.cells
        if kind != _PATH:
            total += manhattan(site, st, pot, b, c, shape)
        elif s == rules.INITIAL:
            total += pot.yard[b, c]
        else:
            if pot.field_comp[b] != c:
                measure_field(site, st, pot, b, c, shape)
                pot.field_comp[b] = c
            total += path_length(site, st, pot, b, c, shape)
    return -float(total)


@kernel
def goal(site, pot, shape, b, c, t):
    """The position (first cell) at which component ``c``, shaped as ``shape[b, c]``, covers
    target ``t``'s cells, or -1 (``multicrane.sim.shortest_paths.goal_positions``)."""
    n = site.length[c]
    if site.length[t] != n:
        return -1
    first = shape[b, c, 0]
    for i in range(n):
        pot.rel[i] = shape[b, c, i] - first
        pot.sorted_cells[i] = site.target_cells[t, i]
    _sort(pot.rel, n)
    _sort(pot.sorted_cells, n)
    start = pot.sorted_cells[0] - pot.rel[0]
    for i in range(n):
        if start + pot.rel[i] != pot.sorted_cells[i]:
            return -1
    return start


@kernel
def _sort(a, n):
    """Insertion sort of ``a[:n]`` in place (a few cells)."""
    for i in range(1, n):
        v, j = a[i], i - 1
        while j >= 0 and a[j] > v:
            a[j + 1] = a[j]
            j -= 1
        a[j + 1] = v


@kernel
def manhattan(site, st, pot, b, c, shape):
    """Cells from the component's first cell to the nearest goal of a free compatible
    target, 0 when none (``DistancePotential._distance``)."""
    here = shape[b, c, 0]
    best = -1
    for k in range(site.compatible.shape[1]):
        t = site.compatible[c, k]
        if t < 0:
            break
        if st.filled_by[b, t] >= 0:
            continue
        g = goal(site, pot, shape, b, c, t)
        if g < 0:
            continue
        d = 0
        for a in range(3):
            d += abs(pot.coords[g, a] - pot.coords[here, a])
        if best < 0 or d < best:
            best = d
    return max(best, 0)


@kernel
def path_length(site, st, pot, b, c, shape):
    """Moves from the component's position down ``pot.field[b]``; where the field does not
    reach it, the Manhattan distance (``PathPotential._distance``)."""
    d = pot.field[b, shape[b, c, 0]]
    return d if d >= 0 else manhattan(site, st, pot, b, c, shape)


@kernel
def measure_field(site, st, pot, b, c, shape):
    """``pot.field[b]``: moves to the nearest goal of a free compatible target for ``c``,
    over the positions where it fits with every component not in transit fixed
    (``PathPotential._field``: ``fits_everywhere`` and ``breadth_first``)."""
    P = len(pot.ok)
    own = c + 1
    for p in range(P):
        v = st.occ[b, p]
        pot.free[p] = v == 0 or v == own or (v > 0 and st.status[b, v - 1] == rules.IN_TRANSIT)
    first = shape[b, c, 0]
    for p in range(P):
        fits = True
        for i in range(site.length[c]):
            q = p + shape[b, c, i] - first
            if q < 0 or q >= P or not pot.free[q]:
                fits = False
                break
        pot.ok[p] = fits
        pot.field[b, p] = -1
    head = tail = 0
    for k in range(site.compatible.shape[1]):
        t = site.compatible[c, k]
        if t < 0:
            break
        if st.filled_by[b, t] >= 0:
            continue
        g = goal(site, pot, shape, b, c, t)
        if g >= 0 and pot.ok[g] and pot.field[b, g] < 0:
            pot.field[b, g] = 0
            pot.queue[tail] = g
            tail += 1
    while head < tail:
        p = pot.queue[head]
        head += 1
        for m in range(len(site.move_delta)):
            q = p + site.move_delta[m]
            if 0 <= q < P and pot.ok[q] and pot.field[b, q] < 0:
                pot.field[b, q] = pot.field[b, p] + 1
                pot.queue[tail] = q
                tail += 1
