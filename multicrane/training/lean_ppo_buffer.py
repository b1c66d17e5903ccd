"""The lean PPO's rollout: preallocated tensors for ``n_steps`` x ``B`` steps, and GAE.

One rollout is ``n_steps`` steps of every row (``[T, B]`` tensors: a row is a paper copy, or
one crane of a motion copy, so GAE runs per crane; observations as the env gives them);
``compute_gae`` turns its rewards, values and episode ends into advantages and returns
(Schulman et al. 2016). A copy whose episode ended by truncation has already had
``gamma * V(final_obs)`` added to its reward (the learner does it when it steps), so an
episode end cuts the bootstrap whatever its cause.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch as th


def compute_gae(rewards: th.Tensor, values: th.Tensor, dones: th.Tensor, last_values: th.Tensor,
                gamma: float, gae_lambda: float) -> tuple[th.Tensor, th.Tensor]:  # fmt: skip
    """(advantages, returns) of a rollout: ``rewards``, ``values`` (of each step's
    observation) and ``dones`` (the episode ended with that step) are ``[T, B]``;
    ``last_values`` ``[B]`` values the observations after the last step."""
    advantages = th.zeros_like(rewards)
    running = th.zeros_like(last_values)
    next_values = last_values
    for t in reversed(range(rewards.shape[0])):
        going_on = 1.0 - dones[t]
        delta = rewards[t] + gamma * next_values * going_on - values[t]
        running = delta + gamma * gae_lambda * going_on * running
        advantages[t] = running
        next_values = values[t]
    return advantages, advantages + values


@dataclass
class Rollout:
    """``n_steps`` x ``n_envs`` steps on ``device``: what the update needs of each."""

    obs: th.Tensor  # [T, B, D] as the env gives them, on the CPU (``lean_ppo_net.sparse``)
    masks: th.Tensor  # [T, B, A] int8
    actions: th.Tensor  # [T, B] int64
    log_probs: th.Tensor  # [T, B]
    values: th.Tensor  # [T, B]
    rewards: th.Tensor  # [T, B]: the env's reward, plus gamma V(final_obs) on truncation
    dones: th.Tensor  # [T, B] 1.0 where the episode ended with the step

    @classmethod
    def allocate(cls, n_steps: int, n_envs: int, n_obs: int, n_actions: int, device,
                 obs_dtype: th.dtype = th.uint8) -> Rollout:  # fmt: skip
        def zeros(*shape, dtype=th.float32):
            return th.zeros(shape, dtype=dtype, device=device)

        return cls(
            obs=th.zeros((n_steps, n_envs, n_obs), dtype=obs_dtype),  # CPU: compacted there
            masks=zeros(n_steps, n_envs, n_actions, dtype=th.int8),
            actions=zeros(n_steps, n_envs, dtype=th.int64),
            log_probs=zeros(n_steps, n_envs),
            values=zeros(n_steps, n_envs),
            rewards=zeros(n_steps, n_envs),
            dones=zeros(n_steps, n_envs),
        )
