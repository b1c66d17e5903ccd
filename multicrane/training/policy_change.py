"""How far each PPO update moved the policy: the KL on the update's own states, every action.

SB3's ``train/approx_kl`` averages ``(r - 1) - log r`` over the sampled actions only, so an
update that moves probability onto an action the rollout hardly ever took (waiting, on
hall-4c) reads small while the policy has changed on most states: in a captured update of a
collapsed run the sampled-action estimate read 0.025 while the KL between the whole masked
distributions before and after was 1.72 on the states with a choice (docs/marl-results.md,
"Why PPO from random weights collapsed"). ``PolicyChange`` logs the latter,
``train/policy_kl``: at the end of each rollout it keeps about ``ROWS`` rows evenly spaced
through the rollout buffer (observations and action masks; with masks, only the rows with
more than one allowed action: the others cannot change) with the policy's log-probabilities
there, and after the update it records the mean ``KL(before || after)`` over those rows. No
random numbers are drawn and nothing the learner sees changes, so a run with it learns
exactly what it learns without it (tested).

**A limit** (``max_kl``; ``multicrane train --set max_policy_kl=0.1``): an update whose KL
passes it is made again from its start (parameters and optimizer state restored, the same
rollout) at half the learning rate, then a quarter, then an eighth; if every try passes the
limit, the policy stays where it was and the next rollout brings new data. Like TRPO's line
search, on the KL PPO's clipping does not see. ``train/policy_kl`` is then the kept update's,
``train/policy_kl_rejected`` the first try's, and ``train/updates_backtracked`` and
``train/updates_rejected`` count the updates made smaller and those left out. A run that
never passes the limit learns exactly what it learns without one (tested).

``with_policy_change(model, callback, max_kl)`` adds it before a run's callback for SB3's
on-policy learners with a discrete action and a flat observation (PPO, A2C, MaskablePPO);
other learners get ``callback`` back unchanged (and a ``max_kl`` for them is refused).
"""

from __future__ import annotations

import copy

import numpy as np
import torch as th
from stable_baselines3.common.callbacks import BaseCallback, CallbackList

ROWS = 256  # rows kept per update (the stride is chosen to keep about this many)
TRIES = 3  # smaller tries of an update that passes the limit: 1/2, 1/4, 1/8 of the rate


class PolicyChange(BaseCallback):
    """Records ``train/policy_kl`` after each update; with ``max_kl``, makes an update that
    passes it again, smaller (see the module doc)."""

    def __init__(self, rows: int = ROWS, max_kl: float | None = None):
        super().__init__()
        self.rows = rows
        self.max_kl = max_kl
        self.kept: tuple[th.Tensor, np.ndarray | None, th.Tensor] | None = None
        self.saved: tuple[dict, dict, dict] | None = None
        self.backtracked = self.rejected = 0

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
        if self.max_kl is not None:  # what a smaller try of the update starts from
            policy = self.model.policy
            self.saved = (copy.deepcopy(policy.state_dict()),
                          copy.deepcopy(policy.optimizer.state_dict()),
                          {k: v.copy() for k, v in vars(buffer).items()
                           if isinstance(v, np.ndarray)})  # fmt: skip

    def _kl(self) -> float:
        obs, masks, before = self.kept
        after = self._log_probs(obs, masks)
        p = before.exp()
        return float(th.where(p > 0, p * (before - after), th.zeros_like(p)).sum(-1).mean())

    def _on_rollout_start(self) -> None:
        if self.kept is None:  # before the first update
            return
        kl = self._kl()
        if self.max_kl is not None and kl > self.max_kl:
            self.logger.record("train/policy_kl_rejected", kl)
            kl = self._smaller()
            self.logger.record("train/updates_backtracked", self.backtracked)
            self.logger.record("train/updates_rejected", self.rejected)
        self.logger.record("train/policy_kl", kl)
        self.kept = self.saved = None

    def _on_training_end(self) -> None:
        self._on_rollout_start()  # the last update too

    def _restore(self) -> None:
        policy = self.model.policy
        policy.load_state_dict(self.saved[0])
        policy.optimizer.load_state_dict(copy.deepcopy(self.saved[1]))  # Adam's state in place

    def _smaller(self) -> float:
        """The update made again at 1/2, 1/4, ... of the rate; none if every try passes. The
        buffer, already emptied for the next rollout, holds the update's rollout again for
        the tries and is emptied again after them."""
        model, buffer = self.model, self.model.rollout_buffer
        schedule = model.lr_schedule
        try:
            for k in range(1, TRIES + 1):
                self._restore()
                for name, array in self.saved[2].items():
                    setattr(buffer, name, array.copy())
                buffer.generator_ready, buffer.full = False, True
                model.lr_schedule = lambda progress, f=0.5**k: schedule(progress) * f
                model.train()
                kl = self._kl()
                if kl <= self.max_kl:
                    self.backtracked += 1
                    return kl
            self._restore()
            self.rejected += 1
            return 0.0
        finally:
            model.lr_schedule = schedule
            buffer.reset()

    def _on_step(self) -> bool:
        return True


def checked_max_kl(value, algo) -> float | None:
    """``value`` of ``max_policy_kl`` for a run of ``algo`` (``algorithms.Algorithm``), or
    ``ValueError`` naming what is wrong."""
    from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm

    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float) or not value > 0:
        raise ValueError(f"max_policy_kl={value!r}: must be a positive number")
    if not issubclass(algo.cls, OnPolicyAlgorithm):
        raise ValueError(f"max_policy_kl: {algo.label} is not one of SB3's on-policy learners "
                         "(PPO, A2C, MaskablePPO)")  # fmt: skip
    return float(value)


def with_policy_change(model, callback: BaseCallback, max_kl: float | None = None):
    """``PolicyChange`` (with ``max_kl``) then ``callback`` where ``model`` is an SB3
    on-policy learner with a discrete action and a flat observation; else ``callback``
    (``ValueError`` if a ``max_kl`` was asked for)."""
    from gymnasium import spaces
    from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm

    if (isinstance(model, OnPolicyAlgorithm) and isinstance(model.action_space, spaces.Discrete)
            and isinstance(model.observation_space, spaces.Box)):  # fmt: skip
        return CallbackList([PolicyChange(max_kl=max_kl), callback])
    if max_kl is not None:
        raise ValueError(f"max_policy_kl: {type(model).__name__} is not an on-policy learner "
                         "with a discrete action (PPO, A2C, MaskablePPO)")  # fmt: skip
    return callback
