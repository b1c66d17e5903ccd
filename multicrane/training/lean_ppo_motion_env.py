"""The lean PPO's motion-mode rows: ``MotionVectorEnv``'s B copies x N cranes as B*N rows.

``LeanMotionEnv`` gives the lean PPO (``multicrane.training.lean_ppo``) one shared policy for
every crane, as ``LeanVecEnv`` gives it the paper env: row ``r`` is crane ``r % N`` of copy
``r // N`` (copy-major, as SB3's ``CraneVecEnv``), so each step hands the learner ``B * N``
observations, masks, rewards and episode ends. Every crane of a copy gets the copy's team
reward (or its share with ``reward_mode="split"``) and the copy's end: the env resets an ended
copy in the same step and keeps the old episode's last observations in ``final_obs``, which
the learner bootstraps a truncated row from. With ``shaping > 0`` each row's reward gets the
potential-based term of ``multicrane.training.shaping`` (``lean_ppo_motion_potential``); the
episode returns stay the environment's.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from multicrane.training.lean_ppo_motion_potential import MotionPotential
from multicrane.vector.motion_vector_env import MotionVectorEnv


class LeanMotionEnv:
    """``n_copies`` copies of ``MotionVectorEnv(scenario, ...)`` (``options``: its keywords)
    as ``num_envs = n_copies * n_cranes`` rows; ``step`` returns ``(obs, masks, rewards,
    terminated, truncated, final_obs, episodes)`` over the rows (``final_obs``: the last
    observation of the rows whose episode ended), ``episodes`` one ``{"r", "l", "success"}``
    per copy that ended (the team return of the env's own reward). The arrays are views of
    the env's buffers, overwritten by the next step."""

    def __init__(self, scenario, n_copies: int, shaping: float = 0.0, gamma: float = 0.99,
                 **options):  # fmt: skip
        if not shaping >= 0:
            raise ValueError(f"shaping must be >= 0, got {shaping!r}")
        self.envs = MotionVectorEnv(n_copies, scenario, **options)
        self.n_copies, self.n_cranes = n_copies, self.envs.n_cranes
        self.num_envs = n_copies * self.n_cranes
        self.observation_space = self.envs.single_observation_space
        self.action_space = spaces.Discrete(self.envs.n_actions)
        self.shaping, self.gamma = float(shaping), float(gamma)
        self.potential = MotionPotential(self.envs) if self.shaping else None
        self.phi = np.zeros(n_copies)  # each copy's potential now
        self.returns = np.zeros(n_copies)
        self.lengths = np.zeros(n_copies, dtype=np.int64)
        self.shaped = np.zeros((n_copies, self.n_cranes))

    def _rows(self, array: np.ndarray) -> np.ndarray:
        return array.reshape(self.num_envs, *array.shape[2:])

    def reset(self, seed) -> tuple[np.ndarray, np.ndarray]:
        """Reset every copy (``seed``: as ``MotionVectorEnv.reset``'s)."""
        self.envs.reset(seed=seed)
        self.returns[:] = 0
        self.lengths[:] = 0
        if self.potential is not None:
            self.phi[:] = self.potential.now()
        return self.current()

    def current(self) -> tuple[np.ndarray, np.ndarray]:
        """The present observations and masks, one row per (copy, crane)."""
        buf = self.envs.buffers
        return self._rows(buf.obs), self._rows(buf.masks)

    def step(self, actions: np.ndarray):
        envs = self.envs
        if self.potential is not None:
            self.potential.before_step()
        obs, rewards, terminated, truncated, infos = envs.step(
            actions.reshape(self.n_copies, self.n_cranes)
        )
        ended = terminated[:, 0] | truncated[:, 0]
        self.returns += rewards[:, 0]
        self.lengths += 1
        done = np.flatnonzero(ended)
        episodes = [
            {"r": float(self.returns[i]), "l": int(self.lengths[i]),
             "success": bool(terminated[i, 0])}  # fmt: skip
            for i in done.tolist()
        ]
        self.returns[done] = 0
        self.lengths[done] = 0
        if self.potential is not None:
            rewards = self._shape(rewards, terminated[:, 0], ended)
        return (self._rows(obs), self._rows(envs.buffers.masks), self._rows(rewards),
                self._rows(terminated), self._rows(truncated), self._rows(infos["final_obs"]),
                episodes)  # fmt: skip

    def _shape(self, rewards: np.ndarray, terminated: np.ndarray, ended: np.ndarray
               ) -> np.ndarray:  # fmt: skip
        """``rewards + w * (gamma * phi(s') - phi(s))`` per copy, into ``self.shaped``:
        ``phi(s')`` is 0 where the episode terminated, the final state's where it was
        truncated, and the new state's elsewhere; the new episodes' potentials are kept."""
        after = self.potential.now()
        final = np.where(terminated, 0.0, after)
        cut = np.flatnonzero(ended & ~terminated)
        if cut.size:
            final[cut] = self.potential.final(cut)[cut]
        term = self.shaping * (self.gamma * final - self.phi)
        np.add(rewards, term[:, None], out=self.shaped)
        self.phi[:] = after
        return self.shaped

    def get_state(self) -> dict[str, Any]:
        return {**self.envs.get_state(), "returns": self.returns.copy(),
                "lengths": self.lengths.copy(), "phi": self.phi.copy()}  # fmt: skip

    def set_state(self, saved: dict[str, Any]) -> None:
        self.envs.set_state(saved)
        self.returns[:] = saved["returns"]
        self.lengths[:] = saved["lengths"]
        self.phi[:] = saved["phi"]

    def close(self) -> None:
        self.envs.close()


# What multicrane train takes for the lean PPO's motion mode, and what it refuses (the message).
REFUSED = {
    "auto": "the automatic mode (--auto) is not modelled by the vector motion env",
    "decisions": "task-level decisions need a batched task env (not built yet): motion only",
    "imitate": "imitation (--imitate) is MaskablePPO's (multicrane.training.imitation)",
    "curriculum": "curricula train the set policy (MaskablePPO)",
}


def lean_motion_env(cfg, n_copies: int, gamma: float) -> LeanMotionEnv:
    """The rows a multi-agent ``TrainConfig`` of the ``lean_ppo`` algorithm trains on
    (``gamma``: the shaping term's discount); ConfigError for the options it does not take."""
    from multicrane.training.config import ConfigError

    refused = {
        "auto": cfg.auto, "decisions": cfg.decisions != "motion", "imitate": cfg.imitate,
        "curriculum": cfg.curriculum or cfg.policy != "mlp",
    }  # fmt: skip
    for name, used in refused.items():
        if used:
            raise ConfigError(f"algo='lean_ppo' (multi-agent): {REFUSED[name]}")
    return LeanMotionEnv(cfg.scenario, n_copies, shaping=cfg.shaping_weight, gamma=gamma,
                         n_cranes=cfg.n_cranes, max_steps=cfg.max_steps, events=cfg.events,
                         reward=cfg.reward)  # fmt: skip
