"""The cloning term of PPO after imitation: steps on the teacher's rows after every PPO update.

PPO after imitation of the look-ahead planner leaves the policy where the imitation put it
or makes it worse (docs/marl-results.md). ``TrainConfig.clone_weight`` (``multicrane train
--clone-weight W``) keeps PPO near the imitated policy: after every PPO update, as many
cloning steps as the update took (PPO's ``n_epochs`` x minibatches per rollout), each on
``batch_size`` (PPO's) decision rows of the run's demonstrations (``imitate_demos``; rows
with more than one allowed action), on the actor part of ``imitation.clone``'s loss: the
cross-entropy of the teacher's actions under the masked logits. Each step is made like a
PPO step: PPO's optimizer (Adam, its current learning rate), the gradient clipped to
``max_grad_norm``, then times ``W``. So ``W = 1`` gives the teacher's rows as many steps
of the same gradient size as PPO's own rollout; the critic is left to PPO (the teacher's
returns are not this policy's).

The minibatches are drawn from ``[seed, CLONE_STREAM, n_updates]`` (stateless), and the
optimizer's state is saved with the model, so a run stopped and resumed learns the same
parameters. ``W = 0`` installs nothing: today's runs, bit for bit.

``CloneTerm`` is the SB3 callback (placed before the run monitor, so that its curve points
and checkpoints see the policy after the cloning steps); ``with_cloning`` adds it to a run;
``cloning_nll`` is the loss it lowers, measured without gradients.
"""

from __future__ import annotations

import json

import numpy as np
import torch as th
from stable_baselines3.common.callbacks import BaseCallback, CallbackList

from multicrane.training.config import ConfigError
from multicrane.training.imitation import Demonstrations, DemonstrationsError, load

CLONE_STREAM = 3  # the minibatch draws' seed stream: [run seed, CLONE_STREAM, n_updates]
CHECKED = ("teacher", "scenario", "cranes", "decisions", "episodes", "reward")


def demonstration_rows(cfg) -> Demonstrations:
    """The teacher's rows of ``cfg.imitate_demos`` (written or checked by the run's imitation
    before PPO); ``ConfigError`` when the file is missing, of another setting or without a
    decision row."""
    path = cfg.imitate_demos
    try:
        with np.load(path, allow_pickle=False) as data:
            stored = json.loads(str(data["meta"]))
    except (OSError, KeyError, ValueError) as exc:
        raise ConfigError(f"clone_weight: {path}: no demonstrations to clone ({exc})") from None
    mine = {
        "teacher": cfg.imitate,
        "scenario": cfg.scenario,
        "cranes": cfg.n_cranes,
        "decisions": cfg.decisions,
        "episodes": cfg.imitate_episodes,
        "reward": cfg.reward,
    }
    differ = [k for k in CHECKED if stored.get(k) != mine[k]]
    if differ:
        what = "; ".join(f"{k}: file {stored.get(k)!r} != run {mine[k]!r}" for k in differ)
        raise ConfigError(f"clone_weight: {path}: demonstrations of another setting ({what})")
    try:
        demos = load(path, stored)
    except DemonstrationsError as exc:
        raise ConfigError(f"clone_weight: {exc}") from None
    if not demos.decisions.any():
        raise ConfigError(f"clone_weight: {path}: no row with a choice to clone")
    return demos


def cloning_nll(policy, demos: Demonstrations, batch_size: int = 1024) -> float:
    """The mean cross-entropy of the teacher's actions on ``demos``' decision rows (the loss
    ``CloneTerm`` steps on), without gradients."""
    rows = np.flatnonzero(demos.decisions)
    total = 0.0
    with th.no_grad():
        for start in range(0, len(rows), batch_size):
            idx = rows[start : start + batch_size]
            _, log_prob, _ = policy.evaluate_actions(
                th.as_tensor(demos.observations[idx]), th.as_tensor(demos.actions[idx]),
                action_masks=demos.masks[idx],
            )  # fmt: skip
            total -= float(log_prob.sum())
    return total / max(len(rows), 1)


class CloneTerm(BaseCallback):
    """After each PPO update (seen at the next rollout's start, or at the end of training),
    ``steps`` cloning steps weighted by ``weight`` (see the module doc; None: as many as the
    PPO update's minibatch steps). ``summary`` (a dict the run keeps, e.g. its progress) gets
    ``weight``, ``steps_per_update``, ``decision_rows`` and ``nll``: per update, the mean
    cloning loss of its steps (each measured before its step)."""

    def __init__(self, demos: Demonstrations, weight: float, seed: int, summary: dict,
                 steps: int | None = None):  # fmt: skip
        super().__init__()
        rows = np.flatnonzero(demos.decisions)
        if not len(rows):
            raise ConfigError("clone_weight: the demonstrations have no row with a choice")
        self.obs = th.as_tensor(demos.observations[rows])
        self.actions = th.as_tensor(demos.actions[rows])
        self.masks = demos.masks[rows]
        self.weight, self.seed, self.steps = float(weight), int(seed), steps
        self.summary = summary
        summary.setdefault("weight", self.weight)
        summary.setdefault("decision_rows", len(rows))
        summary.setdefault("nll", [])
        self.seen = 0

    def _on_training_start(self) -> None:
        self.seen = self.model._n_updates
        if self.steps is None:  # PPO's minibatch steps per update
            rollout = self.model.n_steps * self.model.n_envs
            self.steps = self.model.n_epochs * -(-rollout // self.model.batch_size)
        self.summary.setdefault("steps_per_update", self.steps)

    def _on_rollout_start(self) -> None:
        self._after_update()

    def _on_training_end(self) -> None:
        self._after_update()

    def _on_step(self) -> bool:
        return True

    def _after_update(self) -> None:
        updates = self.model._n_updates
        if updates == self.seen:  # no PPO update since the last call
            return
        self.seen = updates
        if self.weight == 0:
            return
        nll = self._step(np.random.default_rng([self.seed, CLONE_STREAM, updates]))
        self.summary["nll"].append(round(nll, 6))
        self.model.logger.record("clone/nll", nll)

    def _step(self, rng: np.random.Generator) -> float:
        """``self.steps`` weighted cloning steps with PPO's optimizer; their mean loss."""
        model, policy = self.model, self.model.policy
        size = min(model.batch_size, len(self.actions))
        policy.set_training_mode(True)
        total = 0.0
        for _ in range(self.steps):
            pick = rng.choice(len(self.actions), size=size, replace=False)
            idx = th.as_tensor(pick)
            _, log_prob, _ = policy.evaluate_actions(
                self.obs[idx], self.actions[idx], action_masks=self.masks[pick]
            )
            loss = -log_prob.mean()
            policy.optimizer.zero_grad()
            loss.backward()
            th.nn.utils.clip_grad_norm_(policy.parameters(), model.max_grad_norm)
            for p in policy.parameters():
                if p.grad is not None:
                    p.grad.mul_(self.weight)
            policy.optimizer.step()
            total += loss.item()
        policy.set_training_mode(False)
        return total / self.steps


def with_cloning(run, monitor: BaseCallback) -> BaseCallback:
    """The callback of a training run (``trainer.Run``): ``monitor`` alone, or the cloning
    term before it when ``run.cfg.clone_weight`` > 0 (its summary: ``run.progress["clone"]``)."""
    cfg = run.cfg
    if not cfg.clone_weight:
        return monitor
    summary = run.progress.setdefault("clone", {})
    term = CloneTerm(demonstration_rows(cfg), cfg.clone_weight, cfg.seed, summary)
    return CallbackList([term, monitor])
