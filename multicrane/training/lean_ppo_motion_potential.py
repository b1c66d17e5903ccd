"""The shaping potential of ``MotionVectorEnv``'s copies: the lean PPO's compiled ``phi``, per copy.

``phi`` is ``multicrane.training.shaping``'s ``DistancePotential`` (the one the SB3 multi-agent
path shapes with): minus the sum, over the components not arrived, assembled or pre-built, of
the Manhattan distance from the component's node 1 (its pick-up pose's while in the yard) to
the nearest pose where it would fill a free compatible target. It is measured by the paper
mode's kernel (``lean_ppo_shaping.potential``: one implementation for both modes; the motion
state has the same arrays). ``MotionPotential`` measures it on every copy's state (``now``)
and on the last state of the episodes that ended in the step (``final``): the env has reset
those copies by then, so that state is put back together from ``final_obs`` (each
component's status and node 1 are in its table row, ``multicrane.envs.observation``) and the
arrays kept before the step (shapes, pick-up poses, filled targets, plus the targets taken by
the components that arrived in the step). Equal to ``DistancePotential`` on the one-site env,
state for state (tests/training/test_lean_ppo_motion.py).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from multicrane.core.codes import Status
from multicrane.training.lean_ppo_shaping import KINDS, allocate, potential
from multicrane.vector.compiled import kernel

_DISTANCE = KINDS.index("distance")
_INITIAL = int(Status.INITIAL)
_ARRIVED = int(Status.ARRIVED)  # and ASSEMBLED after it
ROW = 14  # a component table row: status (4), flags (4), node 1 (3), node 2 (3)


class States(NamedTuple):
    """What ``potential`` reads of a state, per copy (``occ`` only for its typing: the
    distance potential does not read it)."""

    occ: np.ndarray  # (B, P)
    status: np.ndarray  # (B, C)
    cells: np.ndarray  # (B, C, L)
    pickup: np.ndarray  # (B, C, L)
    filled_by: np.ndarray  # (B, C)


@kernel
def _measure(site, st, pot, copies, out):
    for b in copies:
        out[b] = potential(site, st, pot, b, _DISTANCE)


@kernel
def _last_states(site, final_obs, scale, strides, kept, copies):
    """Turn the rows ``copies`` of ``kept`` (the states before the step) into their
    episode's last state, read from crane 0's ``final_obs`` row: each component's status
    and node 1 (its cells moved with it; a component lifted in the step has its pick-up
    pose's shape), and the targets taken by the components that arrived."""
    for b in copies:
        for c in range(kept.status.shape[1]):
            o = site.rows_start + c * ROW
            s = -1
            for i in range(4):
                if final_obs[b, 0, o + i] > 0.5:
                    s = i
            if s < 0:  # off site (site events): its row is zero and nothing moved it
                continue
            node = 0
            for a in range(3):
                cell = int(round(final_obs[b, 0, o + 8 + a] * scale[a]))
                node += (cell + 1 if a < 2 else cell) * strides[a]  # x and y are padded
            was = kept.status[b, c]
            shape = kept.pickup if was == _INITIAL else kept.cells
            first = shape[b, c, 0]
            for i in range(site.length[c]):
                kept.cells[b, c, i] = shape[b, c, i] - first + node
            if s >= _ARRIVED > was:  # arrived in the step (a status only moves forward)
                kept.filled_by[b, site.target_at[node]] = c
            kept.status[b, c] = s


class MotionPotential:
    """``phi`` of every copy of ``envs`` (a ``MotionVectorEnv``): ``now()`` for the present
    states; ``before_step()`` keeps what ``final(copies)`` needs, the potentials of the last
    states of the episodes of ``copies`` that ended in the step."""

    def __init__(self, envs):
        self.envs = envs
        self.pot = allocate(envs)
        site = envs.reference.sim.site
        X, Y, H = envs.scenario.size
        self.scale = np.array([max(X - 1, 1), max(Y - 1, 1), H], dtype=np.float64)
        origin = site.lin(0, 0, 0)
        self.strides = np.array([site.lin(1, 0, 0) - origin, site.lin(0, 1, 0) - origin, 1])
        self.all = np.arange(envs.num_envs)
        self.out = np.zeros(envs.num_envs)
        self.kept: States | None = None

    def _states(self, st) -> States:
        return States(st.occ, st.status, st.cells, st.pickup, st.filled_by)

    def now(self) -> np.ndarray:
        """``phi`` of each copy's present state (the env's next observation's)."""
        _measure(self.envs.site, self._states(self.envs.state), self.pot, self.all, self.out)
        return self.out.copy()

    def before_step(self) -> None:
        st = self.envs.state  # occ is not read: the env's own array stands in for it
        self.kept = States(st.occ, *(a.copy() for a in self._states(st)[1:]))

    def final(self, copies: np.ndarray) -> np.ndarray:
        """``phi`` of the last state of the episodes of ``copies`` (ended in the step just
        taken, after ``before_step``), at those entries; the others are not meaningful."""
        envs = self.envs
        _last_states(envs.site, envs.buffers.final_obs, self.scale, self.strides, self.kept,
                     copies)  # fmt: skip
        _measure(envs.site, self.kept, self.pot, copies, self.out)
        return self.out
