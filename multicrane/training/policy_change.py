"""How far each PPO update moved the policy: the KL on the update's own states, every action.

SB3's ``train/approx_kl`` averages ``(r - 1) - log r`` over the sampled actions only, so an
update that moves probability onto an action the rollout hardly ever took (waiting, on
hall-4c) reads small while the policy has changed on most states: in a captured update of a
collapsed run the sampled-action estimate read 0.025 while the KL between the whole masked
distributions before and after was 1.72 on the states with a choice (docs/marl-results.md, "Why PPO from random weights
collapsed"). ``PolicyChange`` logs the latter, ``train/policy_kl``: at the end of each rollout
it keeps about ``ROWS`` rows evenly spaced through the rollout buffer (observations and
action masks; with masks, only the rows with more than one allowed action: the others cannot
change) with the policy's log-probabilities there, and after the update it records the mean
``KL(before || after)`` over those rows. No random numbers are drawn and nothing the learner
sees changes, so a run with it learns exactly what it learns without it (tested).

``with_policy_change(model, callback)`` adds it before a run's callback for SB3's on-policy
learners with a discrete action and a flat observation (PPO, A2C, MaskablePPO); other
learners get ``callback`` back unchanged.
"""

from __future__ import annotations

import numpy as np
import torch as th
from stable_baselines3.common.callbacks import BaseCallback, CallbackList

ROWS = 256  # rows kept per update (the stride is chosen to keep about this many)


class PolicyChange(BaseCallback):
    """Records ``train/policy_kl`` (see the module doc) after each update."""

    def __init__(self, rows: int = ROWS):
        super().__init__()
        self.rows = rows
        self.kept: tuple[th.Tensor, np.ndarray | None, th.Tensor] | None = None

    def _log_probs(self, obs: th.Tensor, masks: np.ndarray | None) -> th.Tensor:
        policy = self.model.policy
        with th.no_grad():
            if masks is None:
                dist = policy.get_distribution(obs)
            else:
                dist = policy.get_distribution(obs, action_masks=masks)
            return th.log_softmax(dist.distribution.logits, -1)

    def _on_rollout_end(self) -> None:
        buffer = self.model.rollout_buffer
        obs = buffer.observations.reshape(-1, *buffer.obs_shape)
        stride = max(1, len(obs) // self.rows)
        rows = np.arange(0, len(obs), stride)
        masks = getattr(buffer, "action_masks", None)
        if masks is not None:  # the states with a choice: elsewhere nothing can move
            masks = masks.reshape(len(obs), -1)[rows].astype(bool)
            rows, masks = rows[masks.sum(-1) > 1], masks[masks.sum(-1) > 1]
            if not len(rows):
                return
        picked = th.as_tensor(np.ascontiguousarray(obs[rows]), dtype=th.float32)
        self.kept = (picked, masks, self._log_probs(picked, masks))

    def _on_rollout_start(self) -> None:
        if self.kept is None:  # before the first update
            return
        obs, masks, before = self.kept
        after = self._log_probs(obs, masks)
        p = before.exp()
        terms = th.where(p > 0, p * (before - after), th.zeros_like(p))
        self.logger.record("train/policy_kl", float(terms.sum(-1).mean()))
        self.kept = None

    def _on_step(self) -> bool:
        return True


def with_policy_change(model, callback: BaseCallback) -> BaseCallback:
    """``PolicyChange`` then ``callback`` where ``model`` is an SB3 on-policy learner with a
    discrete action and a flat observation; else ``callback``."""
    from gymnasium import spaces
    from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm

    if (isinstance(model, OnPolicyAlgorithm) and isinstance(model.action_space, spaces.Discrete)
            and isinstance(model.observation_space, spaces.Box)):  # fmt: skip
        return CallbackList([PolicyChange(), callback])
    return callback
