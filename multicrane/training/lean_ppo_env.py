"""The lean PPO's environment copies: ``PaperVectorEnv`` with episode tallies and saved state.

``LeanVecEnv`` holds ``n`` copies of a paper configuration (``multicrane.vector``, same-step
autoreset), observed as bytes (the values are whole numbers up to 13, docs/vector.md), and
adds what a training run needs around them: each copy's running return and length (the
episodes that ended come back from ``step``), the learner's shaped reward when asked
(``multicrane.training.lean_ppo_shaping``), and ``get_state``/``set_state`` (every array of
the copies, their generators and potentials included), so that a checkpoint resumes the same
episodes.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from multicrane.training.lean_ppo_shaping import ShapedCopies
from multicrane.vector.paper_vector_env import PaperVectorEnv


class LeanVecEnv:
    """``n_envs`` copies of the paper configuration ``config``; ``step`` returns
    ``(obs, masks, rewards, terminated, truncated, final_obs, episodes)`` where ``final_obs``
    is the last observation of the episodes that ended (rows where ``terminated |
    truncated``) and ``episodes`` a list of ``{"r": return, "l": length, "success": bool}``
    (the env's own reward). ``shaping=(weight, gamma, potential)``: ``rewards`` are the
    learner's shaped rewards (``ShapedCopies``), the episodes' returns still the env's. The
    arrays are the env's buffers, overwritten by the next step."""

    def __init__(self, config: str, n_envs: int, mask_blocked_moves: bool,
                 shaping: tuple[float, float, str] | None = None):  # fmt: skip
        self.envs = PaperVectorEnv(n_envs, config=config, mask_blocked_moves=mask_blocked_moves,
                                   obs_dtype=np.uint8)  # fmt: skip
        self.shaped = None if shaping is None else ShapedCopies(self.envs, *shaping)
        self.num_envs = n_envs
        self.observation_space = self.envs.single_observation_space
        self.action_space = self.envs.single_action_space
        self.returns = np.zeros(n_envs)
        self.lengths = np.zeros(n_envs, dtype=np.int64)

    def reset(self, seed: int) -> tuple[np.ndarray, np.ndarray]:
        if self.shaped is None:
            self.envs.reset(seed=seed)
        else:
            self.shaped.reset(seed)
        self.returns[:] = 0
        self.lengths[:] = 0
        return self.current()

    def current(self) -> tuple[np.ndarray, np.ndarray]:
        """The present observations and masks (after ``reset``, ``step`` or ``set_state``)."""
        return self.envs.buffers.obs, self.envs.buffers.masks

    def step(self, actions: np.ndarray):
        if self.shaped is None:
            self.envs.step(actions)
            learner = self.envs.buffers.rewards
        else:
            learner = self.shaped.step(actions)
        buf = self.envs.buffers
        rewards, terminated, truncated = buf.rewards, buf.terminated, buf.truncated
        self.returns += rewards
        self.lengths += 1
        done = np.flatnonzero(terminated | truncated)
        episodes = [
            {"r": float(self.returns[i]), "l": int(self.lengths[i]),
             "success": bool(terminated[i])}  # fmt: skip
            for i in done.tolist()
        ]
        self.returns[done] = 0
        self.lengths[done] = 0
        return buf.obs, buf.masks, learner, terminated, truncated, buf.final_obs, episodes

    def get_state(self) -> dict[str, Any]:
        shaped = {} if self.shaped is None else {"potentials": self.shaped.get_state()}
        return {**self.envs.get_state(), "returns": self.returns.copy(),
                "lengths": self.lengths.copy(), **shaped}  # fmt: skip

    def set_state(self, saved: dict[str, Any]) -> None:
        self.envs.set_state(saved)
        self.returns[:] = saved["returns"]
        self.lengths[:] = saved["lengths"]
        if self.shaped is not None:
            self.shaped.set_state(saved["potentials"])

    def close(self) -> None:
        self.envs.close()


def lean_vec_env(cfg, algo, n_envs: int, gamma: float) -> LeanVecEnv:
    """The copies a ``TrainConfig`` of the ``lean_ppo`` algorithm trains on (paper mode),
    shaped as ``cfg`` asks with the shaping discount ``gamma``."""
    mask = algo.masked if cfg.mask_blocked_moves is None else cfg.mask_blocked_moves
    w = cfg.shaping_weight
    return LeanVecEnv(cfg.scenario, n_envs, mask, (w, gamma, cfg.potential) if w else None)
