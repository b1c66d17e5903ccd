"""A run's environments: its training vector environment and its evaluation episodes.

``make_vec_env`` builds what a ``TrainConfig`` trains on (paper mode: SB3's vector of
``PaperAssemblyEnv`` copies, shaped when asked; multi-agent mode: ``CraneVecEnv``, or the set
policy's ``SetVecEnv``); ``evaluate_model`` plays the greedy model on the fixed evaluation
seeds (or a curriculum's held-out sites).
"""

from __future__ import annotations

from typing import Any

from stable_baselines3.common.monitor import Monitor

from multicrane.episodes.rollout import evaluate, optimal_returns
from multicrane.training.algorithms import Algorithm
from multicrane.training.config import TrainConfig
from multicrane.training.model_policy import model_policy
from multicrane.training.seeding import VALIDATION_FIRST, evaluation_seeds
from multicrane.training.set_training import (
    SET_COPIES,
    evaluate_on_sites,
    evaluation_sites,
    make_set_vec_env,
)
from multicrane.training.shaping import ShapedPaperEnv
from multicrane.training.vec_env import CraneVecEnv, SeededDummyVecEnv


def paper_env(cfg: TrainConfig, algo: Algorithm):
    from multicrane.envs.paper_env import PaperAssemblyEnv

    mask = algo.masked if cfg.mask_blocked_moves is None else cfg.mask_blocked_moves
    return PaperAssemblyEnv(cfg.scenario, mask_blocked_moves=mask)


def multi_env(cfg: TrainConfig):
    from multicrane.envs.crane_env import MultiCraneEnv

    return MultiCraneEnv(cfg.scenario, n_cranes=cfg.n_cranes, auto=cfg.auto,
                         max_steps=cfg.max_steps, decisions=cfg.decisions,
                         events=cfg.events, reward=cfg.reward)  # fmt: skip


def shaping_gamma(cfg: TrainConfig, params: dict[str, Any]) -> float:
    """The discount in the shaping term: ``cfg.shaping_gamma``, else the learner's own (the
    policy-invariant form)."""
    if cfg.shaping_gamma is not None:
        return float(cfg.shaping_gamma)
    return float(params.get("gamma", 0.99))


def make_vec_env(cfg: TrainConfig, algo: Algorithm, params: dict[str, Any]):
    gamma = shaping_gamma(cfg, params)
    if cfg.policy == "set":
        return make_set_vec_env(cfg, cfg.n_envs or SET_COPIES, gamma)
    n = cfg.n_envs or algo.n_envs
    if algo.name == "lean_ppo" and not cfg.paper:  # the vector motion env, a row per crane
        from multicrane.training.lean_ppo_motion_env import lean_motion_env

        return lean_motion_env(cfg, n, gamma)
    if algo.name == "lean_ppo":  # the vector paper env (multicrane.training.lean_ppo_env)
        from multicrane.training.lean_ppo_env import lean_vec_env

        return lean_vec_env(cfg, algo, n, gamma)
    if cfg.paper:  # shaping: the learner's reward only; Monitor records the paper's
        w, kind = cfg.shaping_weight, cfg.potential
        shape = (lambda e: ShapedPaperEnv(e, w, gamma, kind)) if w else (lambda e: e)
        return SeededDummyVecEnv([lambda: shape(Monitor(paper_env(cfg, algo)))] * n)
    return CraneVecEnv(lambda: multi_env(cfg), n, shaping=cfg.shaping_weight, gamma=gamma)


# -- evaluation --------------------------------------------------------------------------------


def evaluate_model(model, cfg: TrainConfig, algo: Algorithm, episodes: int, optimal: bool,
                   validation: bool = False):  # fmt: skip
    """Greedy episodes of the model on the evaluation seeds: (episodes, summary), with the
    gap to the exact planner's returns on the same seeds when ``optimal`` (paper mode).
    ``validation``: on the validation seeds instead (``VALIDATION_FIRST`` ...: choosing a
    model on them leaves the evaluation episodes unseen)."""
    seeds = evaluation_seeds(episodes, *([VALIDATION_FIRST] if validation else []))
    if cfg.curriculum is not None:  # one episode per site: held-out, or validation train sites
        sites = evaluation_sites(cfg, episodes, validation)
        return evaluate_on_sites(model, sites, seeds, cfg.max_steps, cfg.reward)
    env = paper_env(cfg, algo) if cfg.paper else multi_env(cfg)
    best = optimal_returns(env, seeds) if optimal and cfg.paper else None
    return evaluate(env, lambda e, s: model_policy(model, e, cfg.paper), seeds, optimal=best)
