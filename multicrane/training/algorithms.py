"""The training algorithms and their default hyper-parameters.

Single-agent benchmark mode: the paper's settings (``docs/paper-spec.md`` section 8). DQN
and double DQN: MLP 64-64, Adam lr 5e-4, batch 64, replay 50,000, target update every 500
gradient steps, one gradient step per env step, epsilon 1.0 -> 0.02 over the first 10 %,
gamma 0.9 (Env1/2) or 0.8 (Env3/4). A2C: 16 envs x 5 steps, RMSprop lr 7e-4, gamma 0.9,
entropy 0.01. PPO: 16 envs x 125 steps, minibatch 64, 4 epochs, lr 3e-4, gamma 0.9, GAE 0.95,
clip 0.2, observations divided by 4. MaskablePPO (not in the paper) uses PPO's settings with
the environment's blocked-move mask. The lean PPO (``lean_ppo``, ours, not an SB3 class:
``multicrane.training.lean_ppo``) trains on the vector paper env with its own defaults.

Multi-agent mode (parameter sharing, one row per crane): PPO and MaskablePPO with settings
of our own (8 copies x 128 steps, 10 epochs, gamma 0.95), with the potential-based shaping
of ``multicrane.training.shaping``: without it, PPO learns to wait forever. The lean PPO
(``lean_ppo``) runs there too, on the vector motion env, with the same shaping
(``multicrane.training.lean_ppo_motion_env``).

Every value can be overridden (``TrainConfig.hyperparams``); ``features`` (ours, not an SB3
setting) picks the features extractor by name (``multicrane.training.grid_cnn``), and
``anneal_lr`` (as the lean PPO's, off by default for SB3's learners) decays the learning rate
linearly to 0 over the run's budget.
"""

from __future__ import annotations

import inspect
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch as th
import torch.nn.functional as F
from gymnasium import spaces
from sb3_contrib import MaskablePPO
from stable_baselines3 import A2C, DQN, PPO
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from stable_baselines3.common.utils import LinearSchedule

from multicrane.training.grid_cnn import features_extractor
from multicrane.training.lean_ppo import LeanPPO, default_hyperparameters, motion_hyperparameters


class DoubleDQN(DQN):
    """DQN with the double-DQN target (van Hasselt et al. 2016): the online network picks the
    next action, the target network values it. SB3's ``DQN`` takes the target network's max."""

    def train(self, gradient_steps: int, batch_size: int = 100) -> None:
        self.policy.set_training_mode(True)
        self._update_learning_rate(self.policy.optimizer)
        losses = []
        for _ in range(gradient_steps):
            data = self.replay_buffer.sample(batch_size, env=self._vec_normalize_env)
            discounts = data.discounts if data.discounts is not None else self.gamma
            with th.no_grad():
                next_actions = self.q_net(data.next_observations).argmax(dim=1, keepdim=True)
                next_q = th.gather(self.q_net_target(data.next_observations), 1, next_actions)
                target_q = data.rewards + (1 - data.dones) * discounts * next_q
            current_q = th.gather(self.q_net(data.observations), 1, data.actions.long())
            loss = F.smooth_l1_loss(current_q, target_q)
            losses.append(loss.item())
            self.policy.optimizer.zero_grad()
            loss.backward()
            th.nn.utils.clip_grad_norm_(self.policy.parameters(), self.max_grad_norm)
            self.policy.optimizer.step()
        self._n_updates += gradient_steps
        self.logger.record("train/n_updates", self._n_updates, exclude="tensorboard")
        self.logger.record("train/loss", float(np.mean(losses)))


class ScaledFlatten(BaseFeaturesExtractor):
    """Flattens the observation and multiplies it by ``scale`` (the paper's PPO divides its
    observations by 4). Part of the policy, so a saved model carries its own scaling."""

    def __init__(self, observation_space: spaces.Box, scale: float = 1.0):
        super().__init__(observation_space, int(np.prod(observation_space.shape)))
        self.scale = float(scale)
        self.flatten = th.nn.Flatten()

    def forward(self, observations: th.Tensor) -> th.Tensor:
        return self.flatten(observations) * self.scale


@dataclass(frozen=True)
class Algorithm:
    """One algorithm: its SB3 class, copies of the environment, and default settings."""

    name: str
    cls: type
    n_envs: int
    masked: bool = False
    off_policy: bool = False
    defaults: dict[str, Any] = field(default_factory=dict)
    obs_scale: float = 1.0
    label: str = ""

    def rollout_steps(self, n_rows: int, hyperparams: dict[str, Any]) -> int:
        """Environment steps (all rows) between two parameter updates."""
        if self.off_policy:
            return int(hyperparams.get("train_freq", 1)) * n_rows
        return int(hyperparams["n_steps"]) * n_rows


_DQN = dict(
    learning_rate=5e-4,
    batch_size=64,
    buffer_size=50_000,
    target_update_interval=500,
    train_freq=1,
    gradient_steps=1,
    exploration_initial_eps=1.0,
    exploration_final_eps=0.02,
    exploration_fraction=0.1,
    learning_starts=100,
    policy_kwargs={"net_arch": [64, 64]},
)
_A2C = dict(n_steps=5, learning_rate=7e-4, gamma=0.9, ent_coef=0.01, use_rms_prop=True)
_PPO = dict(
    n_steps=125,
    batch_size=64,
    n_epochs=4,
    learning_rate=3e-4,
    gamma=0.9,
    gae_lambda=0.95,
    clip_range=0.2,
)

# Single-agent benchmark mode (docs/paper-spec.md section 8); DQN's gamma is per environment.
PAPER_ALGORITHMS: dict[str, Algorithm] = {
    a.name: a
    for a in (
        Algorithm("dqn", DQN, 1, off_policy=True, defaults=_DQN, label="DQN"),
        Algorithm("double_dqn", DoubleDQN, 1, off_policy=True, defaults=_DQN, label="double DQN"),
        Algorithm("a2c", A2C, 16, defaults=_A2C, label="A2C"),
        Algorithm("ppo", PPO, 16, defaults=_PPO, obs_scale=0.25, label="PPO"),
        Algorithm(
            "maskable_ppo",
            MaskablePPO,
            16,
            masked=True,
            defaults=_PPO,
            obs_scale=0.25,
            label="MaskablePPO",
        ),
        # Ours (not the paper's): PPO on the vector env, docs/training.md "The lean PPO".
        Algorithm("lean_ppo", LeanPPO, 256, masked=True, defaults=default_hyperparameters(),
                  obs_scale=0.25, label="lean PPO"),  # fmt: skip
    )
}

_MULTI_PPO = dict(
    _PPO, n_steps=128, batch_size=256, n_epochs=10, gamma=0.95, ent_coef=0.01,
    policy_kwargs={"net_arch": [128, 128]},
)  # fmt: skip

# Multi-agent mode: parameter-sharing PPO, plain or masked.
MULTI_ALGORITHMS: dict[str, Algorithm] = {
    a.name: a
    for a in (
        Algorithm("ppo", PPO, 8, defaults=_MULTI_PPO, label="PPO (shared)"),
        Algorithm(
            "maskable_ppo",
            MaskablePPO,
            8,
            masked=True,
            defaults=_MULTI_PPO,
            label="MaskablePPO (shared)",
        ),
        # Ours: the lean PPO on the vector motion env, one row per crane (docs/training.md).
        Algorithm("lean_ppo", LeanPPO, 32, masked=True, defaults=motion_hyperparameters(),
                  label="lean PPO (shared)"),  # fmt: skip
    )
}


def paper_gamma(config: str) -> float:
    """DQN's discount: 0.9 in Env1/Env2, 0.8 in Env3/Env4 (paper-spec section 8; A2C/PPO: 0.9)."""
    return 0.9 if config.upper()[:2] in ("E1", "E2") else 0.8


def algorithm(name: str, paper: bool) -> Algorithm:
    table = PAPER_ALGORITHMS if paper else MULTI_ALGORITHMS
    if name not in table:
        mode = "the single-agent benchmark mode" if paper else "the multi-agent mode"
        raise ValueError(f"unknown algorithm {name!r} for {mode}: one of {', '.join(table)}")
    return table[name]


# Set by the trainer, not by --set: the seed and logging, and the device: the networks are
# small and the environment is the hot path, so the models live on the CPU even where a GPU
# is visible (the rollout, imitation and deployed policies hand them CPU tensors).
FIXED_SETTINGS = frozenset({"seed", "tensorboard_log", "verbose", "device"})


def hyperparameters(algo: Algorithm, config: str | None, overrides: dict[str, Any]) -> dict:
    """The algorithm's defaults, DQN's gamma for the paper ``config``, then ``overrides``."""
    params = {k: (dict(v) if isinstance(v, dict) else v) for k, v in algo.defaults.items()}
    if config is not None and algo.off_policy:
        params["gamma"] = paper_gamma(config)
    accepted = set(inspect.signature(algo.cls.__init__).parameters) - {"self", "policy", "env"}
    accepted |= {"obs_scale", "features", "anneal_lr", "max_policy_kl"}
    for key, value in overrides.items():
        if key not in accepted or key in FIXED_SETTINGS:
            raise ValueError(
                f"hyperparameter {key!r} is not a setting of {algo.label}: one of "
                f"{', '.join(sorted(accepted - FIXED_SETTINGS))}"
            )
        if key == "features":
            features_extractor(value)  # ValueError naming the choices
        if key == "anneal_lr" and not isinstance(value, bool):
            raise ValueError(f"anneal_lr={value!r}: must be True or False")
        if key == "policy_kwargs" and isinstance(value, dict):
            params["policy_kwargs"] = {**params.get("policy_kwargs", {}), **value}
        else:
            params[key] = value
    return params


def with_lr_schedule(cls: type, params: dict) -> dict:
    """``params`` for constructing ``cls``: with ``anneal_lr``, an SB3 learner's learning rate
    becomes a linear decay from its value to 0 over the run's budget (SB3 reads it against its
    progress, which a resumed run continues). The lean PPO anneals by itself."""
    signature = inspect.signature(cls.__init__).parameters
    if "anneal_lr" in signature:
        return params
    params = dict(params)
    if params.pop("anneal_lr", False):
        start = float(params.get("learning_rate", signature["learning_rate"].default))
        params["learning_rate"] = LinearSchedule(start, 0.0, 1.0)
    return params


def round_gamma(params: dict, decisions: str, reward: str, overrides: dict) -> dict:
    """``params`` with ``gamma`` 1 at the task level with the makespan reward (unless
    ``overrides`` sets it). A task-level step is a decision round of one to many simulated
    steps, and a round in which a crane waits lasts one step: discounted per round, the same
    steps cost less the more rounds they are cut into, so waiting looks cheap and PPO drifts
    to it (docs/marl-results.md, "Why PPO drifted to waiting"). The makespan reward counts
    every step alike; undiscounted, the return is the makespan's own."""
    if decisions == "task" and reward == "makespan" and "gamma" not in overrides:
        return {**params, "gamma": 1.0}
    return params


def make_model(algo: Algorithm, venv, seed: int, params: dict, tensorboard_log: str | None):
    """A fresh SB3 model; the observation scaling goes into the policy."""
    params = with_lr_schedule(algo.cls, params)
    policy_kwargs = dict(params.pop("policy_kwargs", {}))
    obs_scale = float(params.pop("obs_scale", algo.obs_scale))
    extractor = features_extractor(params.pop("features", "flat")) or ScaledFlatten
    policy_kwargs.setdefault("features_extractor_class", extractor)
    policy_kwargs.setdefault("features_extractor_kwargs", {"scale": obs_scale})
    with warnings.catch_warnings():
        # The paper's PPO minibatch (64) does not divide its rollout (16 x 125): SB3 warns.
        warnings.filterwarnings("ignore", message="You have specified a mini-batch size")
        return algo.cls(
            "MlpPolicy",
            venv,
            seed=seed,
            policy_kwargs=policy_kwargs,
            tensorboard_log=tensorboard_log,
            verbose=0,
            device="cpu",
            **params,
        )
