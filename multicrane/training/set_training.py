"""Training the set policy: its default settings, environments, model and site evaluation.

``TrainConfig(policy="set")`` trains ``MaskablePPO`` with ``SetPolicy`` on a ``SetVecEnv``:
one network shared by every crane of task-mode copies of one scenario (limits: the
scenario's own, or ``set_limits``), or of a curriculum's ``train`` sites
(``multicrane.training.curriculum``). The defaults (``SET_PPO``) follow what made PPO work
with parameter sharing elsewhere (Yu et al. 2022, MAPPO): big batches, few epochs, and a
critic reading a global summary with the crane's own token; they keep the learner's share of
the wall time small (rows/s: ``multicrane marl-bench --throughput``).
"""

from __future__ import annotations

import dataclasses
from typing import Any

from multicrane.training.set_obs import SetLimits

# MaskablePPO settings of the set policy (overridable with TrainConfig.hyperparams).
SET_PPO: dict[str, Any] = dict(
    n_steps=64,
    batch_size=512,
    n_epochs=4,
    learning_rate=3e-4,
    gamma=0.99,
    gae_lambda=0.95,
    clip_range=0.2,
    ent_coef=0.01,
    policy_kwargs={"features_extractor_kwargs": {"dim": 64, "heads": 0}},
    max_policy_kl=0.1,  # an update past it is made again smaller (policy_change.py)
)
SET_COPIES = 8


def set_hyperparameters(overrides: dict[str, Any]) -> dict[str, Any]:
    """``SET_PPO`` with ``overrides`` (policy_kwargs merged one level down)."""
    from multicrane.training.algorithms import FIXED_SETTINGS

    params = {k: (dict(v) if isinstance(v, dict) else v) for k, v in SET_PPO.items()}
    for key, value in overrides.items():
        if key in FIXED_SETTINGS:
            raise ValueError(f"hyperparameter {key!r} is set by the trainer, not by --set "
                             f"(fixed: {', '.join(sorted(FIXED_SETTINGS))})")  # fmt: skip
        if key == "policy_kwargs" and isinstance(value, dict):
            merged = dict(params["policy_kwargs"])
            for k, v in value.items():
                merged[k] = {**merged.get(k, {}), **v} if isinstance(v, dict) else v
            params["policy_kwargs"] = merged
        else:
            params[key] = value
    return params


def limits_of(cfg) -> SetLimits:
    """The padded table sizes of a run: ``set_limits``, the curriculum's, or the scenario's;
    with the planner's hint column when ``planner_hint``, the support graph's columns when
    ``graph_features``."""
    return dataclasses.replace(_sizes_of(cfg), hint=bool(cfg.planner_hint),
                               graph=bool(cfg.graph_features))  # fmt: skip


def _sizes_of(cfg) -> SetLimits:
    if cfg.curriculum is not None and cfg.set_limits is None:
        from multicrane.training.curriculum import CURRICULA

        return CURRICULA[cfg.curriculum].limits
    if cfg.curriculum is not None:
        return SetLimits(**cfg.set_limits)
    from multicrane.envs.crane_env import MultiCraneEnv

    env = MultiCraneEnv(cfg.scenario, n_cranes=cfg.n_cranes, decisions="task",
                        events=cfg.events)  # fmt: skip
    exact = SetLimits.of(env.observation_layout)  # with event columns if the site has events
    if cfg.set_limits is not None:
        return SetLimits(**cfg.set_limits, events=exact.events)
    return exact


class _Blocks:
    """Builds a run's ``SetVecEnv`` of ``n`` copies in a worker process (picklable)."""

    def __init__(self, cfg, gamma: float):
        self.cfg, self.gamma = cfg, gamma

    def __call__(self, n: int):
        return make_set_vec_env(self.cfg, n, self.gamma, workers=1)


def make_set_vec_env(cfg, n_envs: int, gamma: float, workers: int | None = None):
    """The ``SetVecEnv`` of a run (a curriculum's sites, or copies of its scenario); with
    ``workers`` > 1 (default: ``cfg.workers``) its copies run in that many processes
    (``multicrane.training.set_workers``)."""
    workers = cfg.workers if workers is None else workers
    if workers > 1:
        from multicrane.training.set_workers import WorkerSetVecEnv

        return WorkerSetVecEnv(_Blocks(cfg, gamma), n_envs, workers)
    from multicrane.envs.crane_env import MultiCraneEnv
    from multicrane.training.set_vec_env import SetVecEnv

    limits = limits_of(cfg)
    if cfg.curriculum is not None:
        from multicrane.training.curriculum import SiteCurriculum

        sites = SiteCurriculum(cfg.curriculum, n_envs, max_steps=cfg.max_steps,
                               reward=cfg.reward)  # fmt: skip
        return SetVecEnv(sites.first_env, n_envs, limits, cfg.shaping_weight, gamma, sites,
                         reward_scale=cfg.reward_scale)  # fmt: skip

    def make(copy: int):
        return MultiCraneEnv(cfg.scenario, n_cranes=cfg.n_cranes, max_steps=cfg.max_steps,
                             decisions="task", events=cfg.events,
                             reward=cfg.reward)  # fmt: skip

    return SetVecEnv(make, n_envs, limits, cfg.shaping_weight, gamma,
                     reward_scale=cfg.reward_scale)


def make_set_model(venv, seed: int, params: dict[str, Any], tensorboard_log: str | None):
    """A fresh MaskablePPO with ``SetPolicy`` sized to ``venv.limits``."""
    from sb3_contrib import MaskablePPO

    from multicrane.training.algorithms import with_lr_schedule
    from multicrane.training.set_policy import SetPolicy

    # max_policy_kl: the training run's callback applies it (policy_change.py)
    params = with_lr_schedule(MaskablePPO, {k: v for k, v in params.items()
                                            if k != "max_policy_kl"})  # fmt: skip
    policy_kwargs = dict(params.pop("policy_kwargs", {}))
    fx = dict(policy_kwargs.pop("features_extractor_kwargs", {}))
    fx["limits"] = venv.limits.to_dict()
    policy_kwargs["features_extractor_kwargs"] = fx
    return MaskablePPO(
        SetPolicy,
        venv,
        seed=seed,
        policy_kwargs=policy_kwargs,
        tensorboard_log=tensorboard_log,
        verbose=0,
        device="cpu",  # small networks; see algorithms.FIXED_SETTINGS
        **params,
    )


def evaluation_sites(cfg, episodes: int, validation: bool = False) -> list[tuple[str, Any]]:
    """(name, scenario) of the sites a curriculum run is evaluated on: the first
    ``episodes`` sites of ``test-small`` (never trained on); ``validation``: as many train
    sites outside the curriculum's pools (``curriculum.validation_pool``), for choosing a
    model without looking at the test sites."""
    if validation:
        from multicrane.training.curriculum import _site, validation_pool

        return [(f"train/{s}", _site(s)) for s in validation_pool(cfg.curriculum, episodes)]
    from multicrane.scenario.named_sets import members

    return [(m.name, m.scenario()) for m in members("test-small")[:episodes]]


def evaluate_on_sites(model, sites, seeds, max_steps: int | None = None, reward: str = "paper"):
    """Greedy episodes of a set model, one per (site, seed) pair: (episodes, summary)."""
    from multicrane.envs.crane_env import MultiCraneEnv
    from multicrane.episodes.rollout import run_episode, summarise
    from multicrane.training.model_policy import SetModelPolicy

    episodes = []
    for (name, scenario), seed in zip(sites, seeds, strict=True):
        env = MultiCraneEnv(scenario, decisions="task", max_steps=max_steps, reward=reward)
        episode = run_episode(env, SetModelPolicy(model, env), seed=seed)
        episode["site"] = name
        episodes.append(episode)
    return episodes, summarise(episodes)
