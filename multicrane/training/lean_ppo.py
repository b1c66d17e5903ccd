"""A lean PPO (cleanrl style) on the vector envs: rollouts and updates in one process.

``LeanPPO`` is the ``lean_ppo`` algorithm of ``multicrane train`` (docs/training.md), in the
paper mode (``lean_ppo_env``: a row per copy) and the multi-agent motion mode
(``lean_ppo_motion_env``: one policy shared by the cranes, a row per crane of each copy; every
row has its own reward, value and advantages, the env's same-step autoreset ends all the rows
of a copy): masked logits (``lean_ppo_net``), GAE (``lean_ppo_buffer``), the clipped
objective with optional value clipping, advantage normalisation, an entropy bonus,
gradient-norm clipping and a learning rate annealed linearly to 0 over the run's budget. It
speaks the part of
stable-baselines3's interface that the trainer uses (``learn`` with a callback,
``num_timesteps``, ``save``/``load``, ``predict``, ``policy``, ``logger``,
``ep_info_buffer``), so ``multicrane.training.trainer.Run`` checkpoints, resumes, evaluates and
saves it as it does the SB3 models. Truncated episodes are bootstrapped from ``final_obs``.

Every random draw (initial weights, actions, minibatches) comes from the learner's own
``torch.Generator``, saved in ``model.zip``: on the CPU the same seed gives the same weights,
and a resumed run the weights of an uninterrupted one (tests/training/test_lean_ppo.py).
``train_device="cuda"`` trains on a GPU; saved weights are always CPU tensors.
"""

from __future__ import annotations

import inspect
import time
from collections import deque
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import torch as th
from gymnasium import spaces

from multicrane.training.lean_ppo_buffer import Rollout, compute_gae
from multicrane.training.lean_ppo_log import Scalars, UpdateStats
from multicrane.training.lean_ppo_net import (
    ActorCritic,
    Sparse,
    log_prob_entropy,
    sample,
    sparse,
)

NET_ARCH = (64, 64)  # the shared sparse layer's units, then each head's hidden layers
NOT_SETTINGS = ("self", "policy", "env", "tensorboard_log", "verbose", "seed", "device")


class Shapes:
    """The spaces of a model that only acts (``LeanPPO.load`` without an environment)."""

    def __init__(self, n_obs: int, n_actions: int):
        self.observation_space = spaces.Box(0, 1, (n_obs,))
        self.action_space = spaces.Discrete(n_actions)


def motion_hyperparameters() -> dict[str, Any]:
    """The multi-agent motion mode's defaults (the ``lean_ppo`` row of the multi-agent
    table): the paper mode's, with the SB3 multi-agent discount 0.95 and a 128-128 network."""
    return {**default_hyperparameters(), "gamma": 0.95, "policy_kwargs": {"net_arch": [128, 128]}}


def default_hyperparameters() -> dict[str, Any]:
    """``LeanPPO``'s settings and their defaults (the ``lean_ppo`` algorithm's table)."""
    signature = inspect.signature(LeanPPO.__init__).parameters.items()
    params = {k: p.default for k, p in signature if k not in NOT_SETTINGS}
    return {**params, "policy_kwargs": {"net_arch": list(NET_ARCH)}}


class _NoCallback:
    def init_callback(self, model) -> None: ...
    def on_training_start(self, locals_, globals_) -> None: ...
    def on_rollout_start(self) -> None: ...
    def on_step(self) -> bool:
        return True

    def on_rollout_end(self) -> None: ...
    def on_training_end(self) -> None: ...


class LeanPPO:
    """PPO on a ``LeanVecEnv`` or ``LeanMotionEnv`` (``env``, ``num_envs`` rows; ``Shapes``
    for a model that only acts). ``policy`` is
    accepted for the trainer's ``make_model`` (``"MlpPolicy"``); ``policy_kwargs``:
    ``net_arch`` (default ``[64, 64]``: the shared sparse layer, then one hidden layer per
    head) and the observation scale in ``features_extractor_kwargs`` (``obs_scale``)."""

    masked_policy = True  # acts on the environment's action masks (model_policy passes them)

    def __init__(
        self,
        policy: str,
        env,
        learning_rate: float = 1e-3,
        n_steps: int = 32,
        batch_size: int = 1024,
        n_epochs: int = 4,
        gamma: float = 0.9,
        gae_lambda: float = 0.95,
        clip_range: float = 0.2,
        clip_range_vf: float | None = None,
        normalize_advantage: bool = True,
        ent_coef: float = 0.01,
        vf_coef: float = 0.5,
        max_grad_norm: float = 0.5,
        anneal_lr: bool = True,
        train_device: str = "cpu",
        policy_kwargs: dict[str, Any] | None = None,
        tensorboard_log: str | None = None,
        verbose: int = 0,  # taken for make_model's call; the lean PPO prints nothing
        seed: int = 0,
        device: str = "cpu",
    ):
        kwargs = dict(policy_kwargs or {})
        extractor = kwargs.pop("features_extractor_class", None)
        if extractor is not None and extractor.__name__ != "ScaledFlatten":
            raise ValueError(f"lean_ppo has its own network: features={extractor.__name__!r} "
                             "is an SB3 features extractor (leave 'features' unset)")  # fmt: skip
        obs_scale = float(kwargs.pop("features_extractor_kwargs", {}).get("scale", 1.0))
        net_arch = list(kwargs.pop("net_arch", NET_ARCH))
        if kwargs:
            raise ValueError(f"policy_kwargs {sorted(kwargs)}: lean_ppo takes net_arch only")
        self.settings = dict(
            learning_rate=float(learning_rate), n_steps=int(n_steps), batch_size=int(batch_size),
            n_epochs=int(n_epochs), gamma=float(gamma), gae_lambda=float(gae_lambda),
            clip_range=float(clip_range), clip_range_vf=clip_range_vf,
            normalize_advantage=bool(normalize_advantage), ent_coef=float(ent_coef),
            vf_coef=float(vf_coef), max_grad_norm=float(max_grad_norm),
            anneal_lr=bool(anneal_lr), train_device=str(train_device),
            policy_kwargs={"net_arch": net_arch, "features_extractor_kwargs": {"scale": obs_scale}},
        )  # fmt: skip
        acting = isinstance(env, Shapes)
        self.env = None if acting else env
        self.seed = int(seed)
        self.device = th.device(device if acting else train_device)
        n_obs, n_actions = int(env.observation_space.shape[0]), int(env.action_space.n)
        self.n_obs, self.n_actions = n_obs, n_actions
        self.observation_space = spaces.Box(0, 1, (n_obs,))  # the shape, for policies.factory
        self.action_space = spaces.Discrete(n_actions)
        self.generator = th.Generator(device=self.device)
        self.generator.manual_seed(self.seed)
        with th.random.fork_rng(devices=[]):  # the weights from the seed, not the global state
            th.manual_seed(self.seed)
            self.policy = ActorCritic(n_obs, n_actions, net_arch, obs_scale).to(self.device)
        self.optimizer = th.optim.Adam(self.policy.parameters(), lr=learning_rate, eps=1e-5,
                                       fused=True)  # one kernel per step: a third faster here
        self.num_timesteps = 0
        self.n_updates = 0
        self.started = False
        self.ep_info_buffer: deque = deque(maxlen=100)
        self.tensorboard_log = tensorboard_log
        self.logger = Scalars()
        self.rollout = None

    @property
    def n_envs(self) -> int:
        return self.env.num_envs

    def _check_settings(self) -> None:
        s = self.settings
        rollout = s["n_steps"] * self.n_envs
        if s["n_steps"] < 1 or s["n_epochs"] < 1 or not 1 <= s["batch_size"] <= rollout:
            raise ValueError(
                f"lean_ppo: n_steps={s['n_steps']}, n_epochs={s['n_epochs']} must be >= 1 and "
                f"batch_size={s['batch_size']} in 1..n_steps x copies ({rollout})"
            )

    # -- learning --------------------------------------------------------------------------

    def learn(self, total_timesteps: int, callback=None, reset_num_timesteps: bool = True,
              tb_log_name: str = "lean_ppo") -> LeanPPO:  # fmt: skip
        """Train until ``num_timesteps`` reaches ``total_timesteps`` (plus the steps so far,
        unless ``reset_num_timesteps``), as SB3's ``learn``: the callback's ``on_step`` after
        each vector step (False stops), ``on_rollout_start`` before each rollout."""
        self._check_settings()
        if reset_num_timesteps:
            self.num_timesteps = 0
        total = int(total_timesteps) + self.num_timesteps
        callback = callback or _NoCallback()
        if self.tensorboard_log is not None:
            self.logger.open(Path(self.tensorboard_log) / tb_log_name)
        if not self.started:
            self.env.reset(seed=self.seed)
            self.started = True
        if self.rollout is None:  # observations stored as the env gives them (bytes, floats)
            s, obs_dtype = self.settings, th.from_numpy(self.env.current()[0][:0]).dtype
            self.rollout = Rollout.allocate(s["n_steps"], self.n_envs, self.n_obs,
                                            self.n_actions, self.device, obs_dtype)  # fmt: skip
        callback.init_callback(self)
        callback.on_training_start(locals(), globals())
        try:
            while self.num_timesteps < total:
                start, began = self.num_timesteps, time.perf_counter()
                callback.on_rollout_start()
                if not self._collect(callback):
                    break
                callback.on_rollout_end()
                stats = self._update(1.0 - start / total)
                stats.record(self.logger, self, time.perf_counter() - began)
        finally:
            callback.on_training_end()
            self.logger.close()
        return self

    def _tensor(self, array: np.ndarray) -> th.Tensor:
        return th.from_numpy(array).to(self.device)

    def _sparse(self, obs: np.ndarray):
        return sparse(obs).to(self.device)

    @th.no_grad()
    def _collect(self, callback) -> bool:
        """One rollout into ``self.rollout``; False when the callback stopped it."""
        buf, gamma, policy = self.rollout, self.settings["gamma"], self.policy
        obs, masks = self.env.current()
        for t in range(self.settings["n_steps"]):
            buf.obs[t] = th.from_numpy(obs)
            buf.masks[t].copy_(self._tensor(masks))
            logits, values = policy.logits_and_value(self._sparse(obs), buf.masks[t])
            actions = sample(logits, self.generator)
            buf.actions[t] = actions
            buf.log_probs[t] = log_prob_entropy(logits, actions)[0]
            buf.values[t] = values
            obs, masks, rewards, terminated, truncated, final_obs, episodes = self.env.step(
                actions.cpu().numpy()
            )
            buf.rewards[t].copy_(self._tensor(rewards))
            cut = np.flatnonzero(truncated & ~terminated)
            if cut.size:  # bootstrap a truncated episode from its last observation
                index = self._tensor(cut)
                buf.rewards[t, index] += gamma * policy.value(self._sparse(final_obs[cut]))
            buf.dones[t].copy_(self._tensor(terminated | truncated))
            self.ep_info_buffer.extend(episodes)
            self.num_timesteps += self.n_envs
            if not callback.on_step():
                return False
        return True

    def _update(self, progress_remaining: float) -> UpdateStats:
        """The epochs of minibatch updates on the rollout just collected."""
        s, buf = self.settings, self.rollout
        lr = s["learning_rate"] * (max(progress_remaining, 0.0) if s["anneal_lr"] else 1.0)
        for group in self.optimizer.param_groups:
            group["lr"] = lr
        with th.no_grad():
            last = self.policy.value(self._sparse(self.env.current()[0]))
            advantages, returns = compute_gae(buf.rewards, buf.values, buf.dones, last,
                                              s["gamma"], s["gae_lambda"])  # fmt: skip
        obs = self._sparse(buf.obs.flatten(0, 1).numpy())
        flat = {
            "masks": buf.masks.flatten(0, 1),
            "actions": buf.actions.flatten(), "log_probs": buf.log_probs.flatten(),
            "values": buf.values.flatten(), "advantages": advantages.flatten(),
            "returns": returns.flatten(),
        }  # fmt: skip
        stats = UpdateStats(lr, buf.values.flatten(), returns.flatten())
        n, size = flat["actions"].shape[0], s["batch_size"]
        for _ in range(s["n_epochs"]):
            order = th.randperm(n, generator=self.generator, device=self.device)
            for first in range(0, n, size):
                rows = order[first:first + size]
                batch = {k: v[rows] for k, v in flat.items()}
                stats.add(*self._minibatch(obs.rows(rows), batch))
        self.n_updates += s["n_epochs"]
        return stats

    def _minibatch(self, obs: Sparse, batch: dict[str, th.Tensor]) -> tuple[float, ...]:
        """One gradient step; (policy loss, value loss, entropy, approx. KL, clip fraction)."""
        s = self.settings
        logits, values = self.policy.logits_and_value(obs, batch["masks"])
        log_probs, entropy = log_prob_entropy(logits, batch["actions"])
        log_ratio = log_probs - batch["log_probs"]
        ratio = log_ratio.exp()
        adv = batch["advantages"]
        if s["normalize_advantage"] and adv.numel() > 1:
            adv = (adv - adv.mean()) / (adv.std() + 1e-8)
        clip = s["clip_range"]
        pg_loss = th.max(-adv * ratio, -adv * ratio.clamp(1 - clip, 1 + clip)).mean()
        if s["clip_range_vf"] is None:
            v_loss = 0.5 * ((values - batch["returns"]) ** 2).mean()
        else:
            old, c = batch["values"], float(s["clip_range_vf"])
            clipped = old + (values - old).clamp(-c, c)
            v_loss = 0.5 * th.max((values - batch["returns"]) ** 2,
                                  (clipped - batch["returns"]) ** 2).mean()  # fmt: skip
        ent = entropy.mean()
        loss = pg_loss - s["ent_coef"] * ent + s["vf_coef"] * v_loss
        self.optimizer.zero_grad()
        loss.backward()
        th.nn.utils.clip_grad_norm_(self.policy.parameters(), s["max_grad_norm"])
        self.optimizer.step()
        with th.no_grad():
            kl = ((ratio - 1) - log_ratio).mean()
            clipped_frac = ((ratio - 1).abs() > clip).float().mean()
        return (pg_loss.item(), v_loss.item(), ent.item(), kl.item(), clipped_frac.item())

    # -- acting ----------------------------------------------------------------------------

    @th.no_grad()
    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True,
                action_masks: Sequence | np.ndarray | None = None):  # fmt: skip
        """SB3's ``predict``: ``(actions, None)`` for one observation or a batch; masked
        actions are never chosen (``action_masks``: non-zero where allowed)."""
        single = np.ndim(observation) == 1
        logits = self._logits(observation, action_masks)
        actions = logits.argmax(-1) if deterministic else sample(logits, self.generator)
        actions = actions.cpu().numpy()
        return (actions[0] if single else actions), state

    @th.no_grad()
    def action_scores(self, observation, action_masks: Sequence | np.ndarray) -> np.ndarray:
        """The masked logits ``[n, A]`` of a batch of observations (``MASKED_LOGIT`` where
        masked): what a greedy multi-agent policy compares across cranes (``model_policy``)."""
        return self._logits(observation, action_masks).cpu().numpy()

    def _logits(self, observation, action_masks) -> th.Tensor:
        obs = self._sparse(np.asarray(observation).reshape(-1, self.n_obs))
        n = obs.cols.shape[0]
        if action_masks is None:
            masks = th.ones(n, self.n_actions, dtype=th.int8, device=self.device)
        else:
            masks = self._tensor(np.asarray(action_masks, dtype=np.int8).reshape(n, -1))
        return self.policy.logits_and_value(obs, masks)[0]

    # -- saving ----------------------------------------------------------------------------

    def save(self, path: str | Path) -> None:
        """Everything a resumed run needs (weights, optimizer, generator, counters) in one
        torch file; the tensors on the CPU."""
        th.save({
            "settings": self.settings, "seed": self.seed, "n_obs": self.n_obs,
            "n_actions": self.n_actions,
            "policy": {k: v.cpu() for k, v in self.policy.state_dict().items()},
            "optimizer": self.optimizer.state_dict(),
            "generator": self.generator.get_state(), "num_timesteps": self.num_timesteps,
            "n_updates": self.n_updates, "started": self.started,
            "ep_info_buffer": list(self.ep_info_buffer),
        }, path)  # fmt: skip

    @classmethod
    def load(cls, path: str | Path, env=None, device: str = "cpu", force_reset: bool = True,
             **_ignored) -> LeanPPO:  # fmt: skip
        """A saved model: with ``env``, ready to go on learning on it (on its
        ``train_device``; the environment's state is the caller's, as in a checkpoint);
        without, to act (on ``device``)."""
        saved = th.load(path, map_location="cpu", weights_only=False)
        shapes = env if env is not None else Shapes(saved["n_obs"], saved["n_actions"])
        model = cls("MlpPolicy", shapes, seed=saved["seed"], device=device, **saved["settings"])
        model.policy.load_state_dict(saved["policy"])
        model.optimizer.load_state_dict(saved["optimizer"])
        if env is not None:  # going on learning: the draws go on where they stopped
            model.generator.set_state(saved["generator"])
        model.num_timesteps, model.n_updates = saved["num_timesteps"], saved["n_updates"]
        model.started = saved["started"] and not force_reset
        model.ep_info_buffer.extend(saved["ep_info_buffer"])
        return model
