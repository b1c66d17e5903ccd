"""The lean PPO's scalars: per-update statistics, written to TensorBoard when it is installed.

``Scalars`` is the ``logger`` of ``LeanPPO`` (the trainer records its evaluations with
``record``, as on an SB3 logger); ``open`` starts a ``torch.utils.tensorboard`` writer in a
run's ``tb/`` folder, and does nothing when TensorBoard is missing. ``UpdateStats`` gathers
one update's losses and writes them, with the training returns and steps per second.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch as th


class Scalars:
    """Scalars recorded between two ``dump``s; written to TensorBoard if it is open."""

    def __init__(self) -> None:
        self.values: dict[str, float] = {}
        self.writer = None

    def open(self, folder: Path) -> None:
        try:
            from torch.utils.tensorboard import SummaryWriter
        except ImportError:  # TensorBoard is optional: no scalars on disk
            return
        self.writer = SummaryWriter(str(folder))

    def record(self, key: str, value, exclude=None) -> None:
        self.values[key] = float(value)

    def dump(self, step: int) -> None:
        if self.writer is not None:
            for key, value in self.values.items():
                self.writer.add_scalar(key, value, step)
        self.values.clear()

    def close(self) -> None:
        if self.writer is not None:
            self.writer.close()
            self.writer = None


class UpdateStats:
    """One update's minibatch losses, its learning rate and the value fit."""

    NAMES = ("policy_loss", "value_loss", "entropy", "approx_kl", "clip_fraction")

    def __init__(self, learning_rate: float, values: th.Tensor, returns: th.Tensor):
        self.learning_rate = learning_rate
        variance = returns.var()
        explained = 1 - (returns - values).var() / variance if variance > 0 else th.tensor(0.0)
        self.explained_variance = float(explained)
        self.rows: list[tuple[float, ...]] = []

    def add(self, *row: float) -> None:
        self.rows.append(row)

    def record(self, logger: Scalars, model, seconds: float) -> None:
        """Write the means of the update, the training episodes' return and success (the
        last 100 episodes) and the rollout-and-update's steps per second, at the model's
        step count."""
        for name, value in zip(self.NAMES, np.mean(self.rows, axis=0), strict=True):
            logger.record(f"train/{name}", value)
        logger.record("train/learning_rate", self.learning_rate)
        logger.record("train/explained_variance", self.explained_variance)
        episodes = model.ep_info_buffer
        if episodes:
            logger.record("rollout/ep_rew_mean", np.mean([e["r"] for e in episodes]))
            logger.record("rollout/ep_len_mean", np.mean([e["l"] for e in episodes]))
            logger.record("rollout/success_rate", np.mean([e["success"] for e in episodes]))
        rollout = model.settings["n_steps"] * model.n_envs
        logger.record("time/steps_per_second", rollout / max(seconds, 1e-9))
        logger.dump(model.num_timesteps)
