"""Potential-based shaping of the learner's reward in paper mode (``ShapedPaperEnv``)."""

from __future__ import annotations

import numpy as np
import pytest
from stable_baselines3.common.monitor import Monitor

from multicrane.optimal import plan
from multicrane.paper_env import PaperAssemblyEnv
from multicrane.training import ConfigError, TrainConfig
from multicrane.training.algorithms import algorithm, hyperparameters
from multicrane.training.shaping import ShapedPaperEnv, potential_from_scratch
from multicrane.training.trainer import make_vec_env, paper_env

W, GAMMA = 0.5, 0.9


def _shaped(config: str, w: float = W, gamma: float = GAMMA) -> ShapedPaperEnv:
    return ShapedPaperEnv(Monitor(PaperAssemblyEnv(config)), w, gamma)


def _optimal_actions(config: str, seed: int) -> tuple[int, ...]:
    env = PaperAssemblyEnv(config)
    env.reset(seed=seed)
    return plan(env=env).actions


@pytest.mark.parametrize("config", ["E1S1", "E2S2", "E3S1"])
def test_the_paper_env_and_its_returns_are_unchanged(config):
    """Same observations, paper reward, ends and Monitor return as the plain env."""
    rng = np.random.default_rng(7)
    actions = rng.integers(0, 6, 400).tolist()
    plain, shaped = PaperAssemblyEnv(config), _shaped(config)
    o1, _ = plain.reset(seed=3)
    o2, _ = shaped.reset(seed=3)
    assert np.array_equal(o1, o2)
    total, differs = 0.0, False
    for a in actions:
        o1, r1, t1, u1, _ = plain.step(a)
        o2, r2, t2, u2, info = shaped.step(a)
        assert np.array_equal(o1, o2) and (t1, u1) == (t2, u2)
        assert info["paper_reward"] == r1
        total += r1
        differs |= r2 != r1
        if t1 or u1:
            break
    assert differs, "the learner's reward is shaped"
    assert info["episode"]["r"] == pytest.approx(total), "Monitor records the paper's return"


@pytest.mark.parametrize("action", range(6))
def test_a_step_adds_w_times_gamma_phi_next_minus_phi(action):
    """Table over the six moves from one hand-reached state (E2S2, a few moves in)."""
    env = _shaped("E2S2")
    env.reset(seed=0)
    for a in (4, 0, 1):  # lift and move the first component
        env.step(a)
    sim = env.unwrapped.sim
    phi = potential_from_scratch(sim)
    assert env.phi == phi
    _, r, terminated, _, info = env.step(action)
    phi_next = 0.0 if terminated else potential_from_scratch(sim)
    assert r == pytest.approx(info["paper_reward"] + W * (GAMMA * phi_next - phi))


def test_the_potential_is_minus_the_distances_and_zero_at_the_end():
    env = _shaped("E1S1")
    env.reset(seed=0)
    assert env.phi == potential_from_scratch(env.unwrapped.sim) < 0
    for a in _optimal_actions("E1S1", 0):
        _, _, terminated, _, _ = env.step(a)
    assert terminated and env.phi == 0.0 == potential_from_scratch(env.unwrapped.sim)


@pytest.mark.parametrize(
    "config,seed,optimal", [("E1S1", 0, True), ("E2S2", 1, True), ("E2S2", 2, False)]
)
def test_the_shaping_terms_telescope_over_an_episode(config, seed, optimal):
    """sum_t gamma^t F_t = w (gamma^T phi(s_T) - phi(s_0)), phi(s_T) = 0 when terminated."""
    env = _shaped(config)
    env.reset(seed=seed)
    phi0 = env.phi
    if optimal:
        actions = _optimal_actions(config, seed)
    else:
        actions = np.random.default_rng(seed).integers(0, 6, 1000).tolist()
    discounted_f, t = 0.0, 0
    for a in actions:
        _, r, terminated, truncated, info = env.step(a)
        discounted_f += GAMMA**t * (r - info["paper_reward"])
        t += 1
        if terminated or truncated:
            break
    assert terminated == optimal and (terminated or truncated)
    phi_end = 0.0 if terminated else potential_from_scratch(env.unwrapped.sim)
    assert discounted_f == pytest.approx(W * (GAMMA**t * phi_end - phi0))


def test_training_copies_are_shaped_and_evaluation_is_not():
    def venv(shaping):
        cfg = TrainConfig("E1S1", paper=True, algo="maskable_ppo", n_envs=2, shaping=shaping)
        algo = algorithm(cfg.algo, True)
        return cfg, algo, make_vec_env(cfg, algo, hyperparameters(algo, cfg.scenario, {}))

    cfg, algo, plain = venv(None)
    assert TrainConfig("E1S1", paper=True).shaping_weight == 0  # the paper's reward
    assert all(isinstance(e, Monitor) for e in plain.envs)
    cfg, algo, shaped = venv(0.5)
    assert all(isinstance(e, ShapedPaperEnv) for e in shaped.envs)
    assert {(e.weight, e.gamma) for e in shaped.envs} == {(0.5, 0.9)}  # PPO's gamma
    shaped.seed(0)
    shaped.reset()
    assert shaped.action_masks().shape == (2, 6)  # reaches the env through the wrappers
    assert isinstance(paper_env(cfg, algo), PaperAssemblyEnv)  # what evaluation builds


def test_bad_weights_are_refused():
    with pytest.raises(ConfigError, match="shaping=-1"):
        TrainConfig("E1S1", paper=True, shaping=-1)
    with pytest.raises(ValueError, match="weight"):
        ShapedPaperEnv(PaperAssemblyEnv("E1S1"), -0.1, 0.9)
    with pytest.raises(ValueError, match="gamma"):
        ShapedPaperEnv(PaperAssemblyEnv("E1S1"), 1.0, 1.5)


def test_a_profile_passes_its_shaping_weight_to_its_runs():
    from dataclasses import replace

    from multicrane.benchmark.profiles import PROFILES, make_sweep

    profile = replace(PROFILES["smoke"], algos=("dqn", "maskable_ppo"), shaping={"dqn": 2.0})
    runs = {r.algo: r.train for r in make_sweep(profile).runs() if r.config == "E1S1"}
    assert TrainConfig(**runs["dqn"]).shaping_weight == 2.0
    assert TrainConfig(**runs["maskable_ppo"]).shaping_weight == 0.0  # the paper's reward
    assert make_sweep(profile).to_dict()["shaping"] == {"dqn": 2.0}


def test_a_shaped_run_resumes_exactly(tmp_path):
    """The wrapper's phi and the potential's caches travel with the checkpointed copies."""
    import torch as th

    from multicrane.training import load_run, train

    cfg = TrainConfig("E1S1", paper=True, algo="maskable_ppo", total_steps=384, n_envs=2,
                      hyperparams={"n_steps": 64, "batch_size": 64, "n_epochs": 1},
                      eval_episodes=1, checkpoint_every=0, shaping=1.0)  # fmt: skip
    train(cfg, tmp_path / "whole", log=lambda *a: None)
    assert train(cfg, tmp_path / "cut", stop_at=150, log=lambda *a: None) is None
    train(cfg, tmp_path / "cut", log=lambda *a: None)
    a, b = (load_run(tmp_path / d)[0].policy.state_dict() for d in ("whole", "cut"))
    assert a.keys() == b.keys() and all(th.equal(a[k], b[k]) for k in a)
