"""One agent for every crane: the multi-agent environment as a single-agent Gymnasium ``Env``.

    env = gymnasium.make("multicrane/Joint-v0", scenario="hall-4c", render_mode="rgb_array")
    env = gymnasium.wrappers.RecordVideo(env, "videos")     # the 'video' extra

For Gymnasium's wrappers and single-agent libraries (``RecordVideo``, vector environments,
MaskablePPO with a ``MultiDiscrete`` action): one action per crane, ``MultiDiscrete([A] * N)``;
the observation is the cranes' flat observation vectors stacked, ``Box(0, 1, (N, D))``;
``action_masks()`` is ``(N, A)`` bool; the reward is the team reward (the sum of the cranes'
terms with ``reward_mode="split"``); ``info`` holds each crane's info by name. Terminated and
truncated as the multi-agent environment is; ``render()`` is its ``render()``. Every other
keyword argument goes to ``MultiCraneEnv`` (``decisions``, ``events``, ``reward``, ...).
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from multicrane.core.schema import Scenario
from multicrane.envs.crane_env import MultiCraneEnv

JOINT_ENV_ID = "multicrane/Joint-v0"


class JointCraneEnv(gym.Env):
    """Every crane of a ``MultiCraneEnv`` driven by one ``MultiDiscrete`` action."""

    metadata = {
        "render_modes": MultiCraneEnv.metadata["render_modes"],
        "render_fps": MultiCraneEnv.metadata["render_fps"],
    }

    def __init__(
        self,
        scenario: str | Path | Scenario = "e2s2",
        n_cranes: int | None = None,
        render_mode: str | None = None,
        **options,
    ):
        self.multi = MultiCraneEnv(
            scenario, n_cranes=n_cranes, render_mode=render_mode, obs_format="flat", **options
        )
        self.render_mode = render_mode
        agents = self.multi.possible_agents
        size = self.multi.observation_space(agents[0]).shape[0]
        self.observation_space = spaces.Box(0.0, 1.0, (len(agents), size), np.float32)
        self.action_space = spaces.MultiDiscrete([self.multi.n_actions] * len(agents))

    @property
    def sim(self):
        """The simulator of the multi-agent environment underneath."""
        return self.multi.sim

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        observations, infos = self.multi.reset(seed=seed, options=options)
        return self._stacked(observations), infos

    def step(self, action):
        agents = self.multi.possible_agents
        joint = np.asarray(action).reshape(len(agents))
        observations, rewards, terminations, truncations, infos = self.multi.step(
            {agent: int(a) for agent, a in zip(agents, joint, strict=True)}
        )
        if self.multi.reward_mode == "team":
            reward = rewards[agents[0]]
        else:
            reward = sum(rewards.values())
        terminated, truncated = terminations[agents[0]], truncations[agents[0]]
        return self._stacked(observations), float(reward), terminated, truncated, infos

    def action_masks(self) -> np.ndarray:
        """``(N, A)`` bool: each crane's legal actions now."""
        return np.stack(list(self.multi.action_masks().values())).astype(bool)

    def render(self):
        return self.multi.render()

    def close(self) -> None:
        self.multi.close()

    def _stacked(self, observations: dict) -> np.ndarray:
        return np.stack([observations[a] for a in self.multi.possible_agents])


__all__ = ["JOINT_ENV_ID", "JointCraneEnv"]
