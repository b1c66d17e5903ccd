"""Training with stable-baselines3: every algorithm path, double DQN, reproducibility, exact
resume, saving and loading, run directories, ``CraneVecEnv``, the plain SuperSuit recipe,
configuration checks and the command line (``multicrane train``), signals included.

Budgets are tiny (hundreds of steps): these tests check the machinery, not learning.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("sb3_contrib")

import gymnasium as gym  # noqa: E402
import torch as th  # noqa: E402
import torch.nn.functional as F  # noqa: E402
from stable_baselines3 import DQN  # noqa: E402
from stable_baselines3.common.logger import configure  # noqa: E402
from stable_baselines3.common.vec_env import DummyVecEnv  # noqa: E402

import multicrane  # noqa: E402
import multicrane.training.trainer as trainer  # noqa: E402
from multicrane.envs.crane_env import MultiCraneEnv  # noqa: E402
from multicrane.envs.paper_env import PaperAssemblyEnv  # noqa: E402
from multicrane.episodes.random_actions import random_legal_action
from multicrane.training import ConfigError, CraneVecEnv, TrainConfig, train  # noqa: E402
from multicrane.training.algorithms import (  # noqa: E402
    MULTI_ALGORITHMS,
    PAPER_ALGORITHMS,
    DoubleDQN,
    ScaledFlatten,
    hyperparameters,
    make_model,
)
from multicrane.training.model_policy import (  # noqa: E402
    PaperModelPolicy,
    SharedModelPolicy,
    load_run,
)
from multicrane.training.seeding import copy_seeds  # noqa: E402
from multicrane.training.trainer import Run  # noqa: E402
from multicrane.training.vec_env import SeededDummyVecEnv  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


pytestmark = pytest.mark.usefixtures("one_torch_thread")


def quiet(*_args, **_kwargs) -> None:
    """A ``log`` for ``train`` that prints nothing."""


def state_dicts_equal(a, b) -> bool:
    sa, sb = a.policy.state_dict(), b.policy.state_dict()
    return sa.keys() == sb.keys() and all(th.equal(sa[k], sb[k]) for k in sa)


def outcomes(episodes: list[dict]) -> list[tuple]:
    """The deterministic part of evaluation episodes (multi-agent ones also carry timings)."""
    return [(e["seed"], e["return"], e["steps"], e["success"]) for e in episodes]


def final_model(run_dir: Path):
    model, _ = load_run(Path(run_dir))
    return model


# -- tiny configurations ---------------------------------------------------------------------

PPO_HP = {"n_steps": 64, "batch_size": 64, "n_epochs": 2}
DQN_HP = {
    "learning_starts": 50,
    "buffer_size": 1000,
    "target_update_interval": 40,
    "exploration_fraction": 0.5,  # epsilon still decays when the run is interrupted
}
MULTI_HP = {"n_steps": 32, "batch_size": 64, "n_epochs": 2}


def tiny(algo: str, **changes) -> TrainConfig:
    """A tiny run of ``algo``: paper mode on E1S1 for ``dqn``/``double_dqn``/``a2c``/``ppo``/
    ``maskable_ppo``; ``multi_ppo``/``multi_maskable_ppo`` for e1s1 with two cranes."""
    if algo.startswith("multi_"):
        kw = dict(
            scenario="e1s1",
            paper=False,
            n_cranes=2,
            algo=algo.removeprefix("multi_"),
            max_steps=30,
            n_envs=2,
            total_steps=512,
            hyperparams=dict(MULTI_HP),
        )
    elif algo in ("dqn", "double_dqn"):
        kw = dict(scenario="E1S1", algo=algo, total_steps=400, hyperparams=dict(DQN_HP))
    elif algo == "a2c":
        kw = dict(scenario="E1S1", algo=algo, total_steps=300, n_envs=2)
    else:
        kw = dict(scenario="E1S1", algo=algo, total_steps=768, n_envs=2, hyperparams=dict(PPO_HP))
    kw.update(eval_episodes=2, checkpoint_every=0)
    kw.update(changes)
    return TrainConfig(**kw)


class References:
    """Uninterrupted runs, trained once per module and shared by the tests that compare
    against them (read-only: nobody trains into these directories again)."""

    def __init__(self, root: Path):
        self.root = root
        self.runs: dict[str, tuple[TrainConfig, Path, dict]] = {}

    def get(self, name: str) -> tuple[TrainConfig, Path, dict]:
        if name not in self.runs:
            cfg = tiny(name)
            run_dir = self.root / name
            result = train(cfg, run_dir, log=quiet)
            self.runs[name] = (cfg, run_dir, result)
        return self.runs[name]


@pytest.fixture(scope="module")
def references(tmp_path_factory) -> References:
    return References(tmp_path_factory.mktemp("reference-runs"))


# -- 1. every algorithm path trains ----------------------------------------------------------


@pytest.mark.parametrize("algo", ["dqn", "double_dqn", "a2c", "ppo", "maskable_ppo"])
def test_paper_algorithm_smoke(algo, tmp_path):
    budget = {"dqn": 200, "double_dqn": 200, "a2c": 200, "ppo": 256, "maskable_ppo": 256}[algo]
    cfg = tiny(algo, total_steps=budget)
    result = train(cfg, tmp_path / "run", log=quiet)
    assert result is not None
    assert result["steps"] >= budget
    assert result["sessions"] == 1
    assert result["algorithm"] == PAPER_ALGORITHMS[algo].label
    final = result["final"]
    assert final["episodes"] == cfg.eval_episodes == len(result["final_episodes"])
    for key in ("return_mean", "optimal_mean", "gap", "gap_pct", "success_rate"):
        assert key in final and final[key] is not None, key
    # The exact planner is optimal: no policy beats it on the same seeds.
    assert final["gap"] == pytest.approx(final["optimal_mean"] - final["return_mean"])
    assert final["gap"] >= -1e-9
    assert (tmp_path / "run" / "model.zip").is_file()
    assert not (tmp_path / "run" / "checkpoint").exists()
    stored = json.loads((tmp_path / "run" / "result.json").read_text())
    assert stored == json.loads(json.dumps(result))
    assert stored["config"] == cfg.to_dict()
    model, loaded_cfg = load_run(tmp_path / "run")
    assert type(model) is PAPER_ALGORITHMS[algo].cls
    assert model.num_timesteps == result["steps"]
    assert loaded_cfg == cfg


@pytest.mark.parametrize("algo", ["ppo", "maskable_ppo"])
def test_multi_agent_algorithm_smoke(algo, tmp_path):
    budget = 256
    cfg = tiny(f"multi_{algo}", total_steps=budget)
    result = train(cfg, tmp_path / "run", log=quiet)
    assert result is not None
    assert result["steps"] >= budget
    # one SB3 row per (copy, crane): the budget counts crane decisions
    rows = cfg.n_envs * cfg.n_cranes
    assert result["steps"] % (MULTI_HP["n_steps"] * rows) == 0
    assert result["algorithm"] == MULTI_ALGORITHMS[algo].label
    final = result["final"]
    assert final["episodes"] == 2
    assert 1 <= final["steps_mean"] <= cfg.max_steps
    assert "makespan_mean" in final and "blocked_moves_mean" in final
    assert (tmp_path / "run" / "model.zip").is_file()
    assert (tmp_path / "run" / "result.json").is_file()
    model, _ = load_run(tmp_path / "run")
    assert type(model) is MULTI_ALGORITHMS[algo].cls


# -- 2. double DQN uses the double target ----------------------------------------------------


class _TinyEnv(gym.Env):
    """Four numbers in, three actions: just enough for a Q-network."""

    observation_space = gym.spaces.Box(-1.0, 1.0, (4,), np.float32)
    action_space = gym.spaces.Discrete(3)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        return np.zeros(4, np.float32), {}

    def step(self, action):
        return np.zeros(4, np.float32), 0.0, False, False, {}


def _dqn_pair(same_target: bool):
    """A ``DoubleDQN`` and a ``DQN`` in identical states (weights, optimizer, replay buffer);
    their target networks equal their online networks, or differ from them."""
    kwargs = dict(
        learning_starts=0,
        buffer_size=64,
        batch_size=32,
        learning_rate=1e-2,
        gamma=0.9,
        policy_kwargs={"net_arch": [16]},
        seed=0,
    )
    double = DoubleDQN("MlpPolicy", DummyVecEnv([_TinyEnv]), **kwargs)
    plain = DQN("MlpPolicy", DummyVecEnv([_TinyEnv]), **kwargs)
    with th.no_grad():
        gen = th.Generator().manual_seed(1)
        for p in double.q_net.parameters():
            p.copy_(th.randn(p.shape, generator=gen))
        for p, q in zip(double.q_net_target.parameters(), double.q_net.parameters(), strict=True):
            p.copy_(q if same_target else th.randn(p.shape, generator=gen))
    plain.policy.load_state_dict(double.policy.state_dict())
    rng = np.random.default_rng(2)
    for _ in range(64):
        obs = rng.uniform(-1, 1, (1, 4)).astype(np.float32)
        nxt = rng.uniform(-1, 1, (1, 4)).astype(np.float32)
        action = rng.integers(3, size=(1, 1))
        reward = rng.normal(size=1).astype(np.float32)
        done = rng.random(1) < 0.2
        for model in (double, plain):
            model.replay_buffer.add(obs, nxt, action, reward, done, [{}])
    for model in (double, plain):
        model.set_logger(configure(None, []))
    return double, plain


def _expected_losses(model, seed: int, batch_size: int) -> tuple[float, float, th.Tensor]:
    """(double-DQN loss, DQN loss, whether online and target argmax differ) on the batch that
    ``train`` draws after ``np.random.seed(seed)``."""
    np.random.seed(seed)  # noqa: NPY002 (SB3's replay buffer samples from the global generator)
    data = model.replay_buffer.sample(batch_size)
    with th.no_grad():
        q_online_next = model.q_net(data.next_observations)
        q_target_next = model.q_net_target(data.next_observations)
        picked = q_online_next.argmax(dim=1, keepdim=True)
        double_next = q_target_next.gather(1, picked)
        plain_next = q_target_next.max(dim=1, keepdim=True).values
        current = model.q_net(data.observations).gather(1, data.actions.long())
        discount = (1 - data.dones) * model.gamma
        double_loss = F.smooth_l1_loss(current, data.rewards + discount * double_next)
        plain_loss = F.smooth_l1_loss(current, data.rewards + discount * plain_next)
    disagree = (picked.squeeze(1) != q_target_next.argmax(dim=1)) & (data.dones.squeeze(1) == 0)
    return float(double_loss), float(plain_loss), disagree


def test_double_dqn_uses_the_double_target():
    double, plain = _dqn_pair(same_target=False)
    double_loss, plain_loss, disagree = _expected_losses(double, seed=7, batch_size=32)
    assert disagree.any(), "the test needs transitions where online and target argmax differ"
    assert double_loss != pytest.approx(plain_loss, rel=1e-6)

    np.random.seed(7)  # noqa: NPY002
    double.train(gradient_steps=1, batch_size=32)
    np.random.seed(7)  # noqa: NPY002
    plain.train(gradient_steps=1, batch_size=32)
    # DoubleDQN's loss is the double-DQN target's, SB3's DQN the max target's.
    assert double.logger.name_to_value["train/loss"] == pytest.approx(double_loss, rel=1e-5)
    assert plain.logger.name_to_value["train/loss"] == pytest.approx(plain_loss, rel=1e-5)
    assert not state_dicts_equal(double, plain)
    # Only the online network learns; the target network is untouched by a gradient step.
    sd = double.policy.state_dict()
    assert any(
        not th.equal(sd[k], plain.policy.state_dict()[k]) for k in sd if k.startswith("q_net.")
    )
    assert all(
        th.equal(sd[k], plain.policy.state_dict()[k]) for k in sd if k.startswith("q_net_target.")
    )


def test_double_dqn_equals_dqn_when_the_networks_agree():
    double, plain = _dqn_pair(same_target=True)
    assert state_dicts_equal(double, plain)
    np.random.seed(7)  # noqa: NPY002
    double.train(gradient_steps=1, batch_size=32)
    np.random.seed(7)  # noqa: NPY002
    plain.train(gradient_steps=1, batch_size=32)
    # With the target network equal to the online one, argmax then target value is the max.
    assert double.logger.name_to_value["train/loss"] == plain.logger.name_to_value["train/loss"]
    assert state_dicts_equal(double, plain)
    assert double._n_updates == plain._n_updates == 1


# -- the paper's settings ----------------------------------------------------------------------


@pytest.mark.parametrize("config", ["E1S1", "E2S3", "E3S2", "E4S4"])
def test_paper_hyperparameters(config):
    """The defaults of ``docs/paper-spec.md`` section 8."""
    dqn_gamma = 0.9 if config[:2] in ("E1", "E2") else 0.8
    for name in ("dqn", "double_dqn"):
        algo = PAPER_ALGORITHMS[name]
        p = hyperparameters(algo, config, {})
        assert algo.n_envs == 1 and algo.off_policy
        assert p["learning_rate"] == 5e-4
        assert p["batch_size"] == 64
        assert p["buffer_size"] == 50_000
        assert p["target_update_interval"] == 500
        assert p["train_freq"] == 1 and p["gradient_steps"] == 1
        assert p["exploration_initial_eps"] == 1.0
        assert p["exploration_final_eps"] == 0.02
        assert p["exploration_fraction"] == 0.1
        assert p["policy_kwargs"]["net_arch"] == [64, 64]
        assert p["gamma"] == dqn_gamma
    assert issubclass(PAPER_ALGORITHMS["double_dqn"].cls, DQN)
    assert PAPER_ALGORITHMS["double_dqn"].cls is DoubleDQN
    assert PAPER_ALGORITHMS["dqn"].cls is DQN

    a2c = PAPER_ALGORITHMS["a2c"]
    p = hyperparameters(a2c, config, {})
    assert a2c.n_envs == 16
    assert (p["n_steps"], p["learning_rate"], p["ent_coef"], p["use_rms_prop"]) == (
        5,
        7e-4,
        0.01,
        True,
    )
    for name in ("ppo", "maskable_ppo"):
        algo = PAPER_ALGORITHMS[name]
        p = hyperparameters(algo, config, {})
        assert algo.n_envs == 16 and algo.obs_scale == 0.25
        assert p["n_steps"] == 125 and p["batch_size"] == 64 and p["n_epochs"] == 4
        assert p["learning_rate"] == 3e-4
        assert p["gae_lambda"] == 0.95 and p["clip_range"] == 0.2
    assert PAPER_ALGORITHMS["maskable_ppo"].masked and not PAPER_ALGORITHMS["ppo"].masked

    # Overrides win, and nested policy_kwargs merge.
    p = hyperparameters(PAPER_ALGORITHMS["dqn"], config, {"gamma": 0.5, "policy_kwargs": {}})
    assert p["gamma"] == 0.5 and p["policy_kwargs"]["net_arch"] == [64, 64]


@pytest.mark.parametrize("config", ["E1S2", "E3S1", "E4S2"])
@pytest.mark.parametrize("name", ["a2c", "ppo"])
def test_paper_a2c_ppo_gamma(config, name):
    """Section 8 (and the paper's appendix A): A2C and PPO use gamma 0.9 in every
    environment; only DQN / double DQN switch to 0.8 in Env3/Env4."""
    p = hyperparameters(PAPER_ALGORITHMS[name], config, {})
    assert p["gamma"] == 0.9, f"{name} on {config}: gamma {p['gamma']}"


@pytest.mark.parametrize("key", ["device", "seed", "verbose"])
def test_trainer_owned_settings_are_refused(key):
    """--set cannot move a model to a GPU (the rollout, imitation and deployed policies hand
    it CPU tensors) nor override the run's seed or logging: a clear error, both tables."""
    from multicrane.training.set_training import set_hyperparameters

    with pytest.raises(ValueError, match=f"'{key}'"):
        hyperparameters(PAPER_ALGORITHMS["dqn"], "E1S1", {key: "cuda"})
    with pytest.raises(ValueError, match=f"'{key}' is set by the trainer"):
        set_hyperparameters({key: "cuda"})


def test_paper_models_carry_their_settings():
    """The built models (not only the tables) have the paper's optimizer and scaling."""
    venv = SeededDummyVecEnv([lambda: PaperAssemblyEnv("E1S1")] * 16)
    a2c = make_model(
        PAPER_ALGORITHMS["a2c"], venv, 0, hyperparameters(PAPER_ALGORITHMS["a2c"], "E1S1", {}), None
    )
    assert isinstance(a2c.policy.optimizer, th.optim.RMSprop)
    assert a2c.n_steps == 5 and a2c.n_envs == 16 and a2c.gamma == 0.9
    ppo_algo = PAPER_ALGORITHMS["ppo"]
    ppo = make_model(ppo_algo, venv, 0, hyperparameters(ppo_algo, "E1S1", {}), None)
    extractor = ppo.policy.features_extractor
    assert isinstance(extractor, ScaledFlatten) and extractor.scale == 0.25
    obs = th.as_tensor(venv.reset()[:2])
    assert th.equal(extractor(obs), obs * 0.25)
    assert ppo.n_steps == 125 and ppo.batch_size == 64 and ppo.n_epochs == 4
    assert a2c.device.type == ppo.device.type == "cpu"  # also where a GPU is visible
    venv.close()


# -- 3. reproducibility ------------------------------------------------------------------------


@pytest.mark.parametrize("algo", ["ppo", "dqn"])
def test_same_seed_same_parameters(algo, references, tmp_path):
    cfg, ref_dir, ref_result = references.get(algo)
    again = train(cfg, tmp_path / "same", log=quiet)
    assert state_dicts_equal(final_model(ref_dir), final_model(tmp_path / "same"))
    assert again["steps"] == ref_result["steps"]
    assert outcomes(again["final_episodes"]) == outcomes(ref_result["final_episodes"])
    other = dataclasses.replace(cfg, seed=1)
    train(other, tmp_path / "other", log=quiet)
    assert not state_dicts_equal(final_model(ref_dir), final_model(tmp_path / "other"))


# -- 4. interrupt and resume -------------------------------------------------------------------


@pytest.mark.parametrize(
    ("name", "stop_at"), [("ppo", 300), ("dqn", 170), ("multi_maskable_ppo", 200)]
)
def test_resume_is_exact(name, stop_at, references, tmp_path):
    cfg, ref_dir, ref_result = references.get(name)
    run_dir = tmp_path / "run"
    messages: list[str] = []
    assert train(cfg, run_dir, stop_at=stop_at, log=messages.append) is None
    algo = (PAPER_ALGORITHMS if cfg.paper else MULTI_ALGORITHMS)[cfg.algo]
    rows = (cfg.n_envs or algo.n_envs) * (cfg.n_cranes or 1)
    params = hyperparameters(algo, cfg.scenario if cfg.paper else None, cfg.hyperparams)
    rollout = algo.rollout_steps(rows, params)
    boundary = math.ceil(stop_at / rollout) * rollout  # the first update boundary >= stop_at
    steps_file = run_dir / "checkpoint" / "steps.txt"
    assert steps_file.is_file()
    assert int(steps_file.read_text()) == boundary
    assert not (run_dir / "result.json").exists() and not (run_dir / "model.zip").exists()
    if algo.off_policy:
        assert (run_dir / "checkpoint" / "replay_buffer.pkl.gz").is_file()
    checkpoint_model, _ = load_run(run_dir, which="checkpoint")
    assert checkpoint_model.num_timesteps == boundary

    messages.clear()
    result = train(cfg, run_dir, log=messages.append)
    assert result is not None
    assert any(f"resuming at step {boundary}" in m for m in messages), messages
    assert result["sessions"] == 2
    assert result["steps"] == ref_result["steps"]  # no step lost or repeated
    assert not (run_dir / "checkpoint").exists()
    resumed = final_model(run_dir)
    reference = final_model(ref_dir)
    assert resumed.num_timesteps == reference.num_timesteps
    assert state_dicts_equal(resumed, reference), (
        f"{name}: parameters after an interruption at {boundary} differ from an uninterrupted run's"
    )
    assert outcomes(result["final_episodes"]) == outcomes(ref_result["final_episodes"])


def test_hard_stop_resumes_from_the_last_periodic_checkpoint(references, tmp_path, monkeypatch):
    """A run killed without warning (a second Ctrl-C) goes back to its last periodic
    checkpoint; periodic checkpoints do not change what is learned."""
    ref_cfg, ref_dir, ref_result = references.get("ppo")
    cfg = dataclasses.replace(ref_cfg, checkpoint_every=256)  # 2 copies x 64 steps = 128/update
    plain_dir = tmp_path / "uninterrupted"
    plain = train(cfg, plain_dir, log=quiet)
    assert not (plain_dir / "checkpoint").exists()
    assert state_dicts_equal(final_model(plain_dir), final_model(ref_dir))

    original = trainer._RunMonitor._on_step

    def crash_late(self):
        if self.model.num_timesteps >= 600:
            raise KeyboardInterrupt
        return original(self)

    monkeypatch.setattr(trainer._RunMonitor, "_on_step", crash_late)
    run_dir = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt):
        train(cfg, run_dir, log=quiet)
    assert int((run_dir / "checkpoint" / "steps.txt").read_text()) == 512
    monkeypatch.setattr(trainer._RunMonitor, "_on_step", original)
    result = train(cfg, run_dir, log=quiet)
    assert result["sessions"] == 2
    assert result["steps"] == plain["steps"] == ref_result["steps"]
    assert state_dicts_equal(final_model(run_dir), final_model(plain_dir))


def test_stop_message_names_the_checkpoint_step(tmp_path):
    """What the log says on stopping is where the run will resume."""
    cfg = tiny("ppo")
    messages: list[str] = []
    assert train(cfg, tmp_path / "run", stop_at=100, log=messages.append) is None
    steps = int((tmp_path / "run" / "checkpoint" / "steps.txt").read_text())
    stopped = [m for m in messages if "stopped at step" in m]
    assert stopped == [f"{cfg.name}: stopped at step {steps}; resume later"], messages


# -- 5. saving, loading and acting ---------------------------------------------------------------


def _paper_observations(n: int = 40) -> np.ndarray:
    env = PaperAssemblyEnv("E1S1")
    rng = np.random.default_rng(0)
    obs, _ = env.reset(seed=5)
    out = []
    for _ in range(n):
        out.append(obs)
        obs, _, term, trunc, _ = env.step(int(rng.integers(6)))
        if term or trunc:
            obs, _ = env.reset()
    return np.stack(out)


@pytest.mark.parametrize("algo", ["ppo", "dqn"])
def test_loaded_model_predicts_like_the_trained_one(algo, tmp_path):
    cfg = tiny(algo, total_steps=256 if algo == "ppo" else 150)
    run = Run(cfg, tmp_path / "run", log=quiet)
    assert run.execute() is not None
    trained = run.model
    loaded, loaded_cfg = load_run(tmp_path / "run")
    assert loaded_cfg == cfg
    obs = _paper_observations()
    a_trained, _ = trained.predict(obs, deterministic=True)
    a_loaded, _ = loaded.predict(obs, deterministic=True)
    assert np.array_equal(a_trained, a_loaded)
    assert state_dicts_equal(trained, loaded)
    with th.no_grad():
        x = th.as_tensor(obs)
        if algo == "ppo":
            p_trained = trained.policy.get_distribution(x).distribution.probs
            p_loaded = loaded.policy.get_distribution(x).distribution.probs
            assert th.equal(p_trained, p_loaded)
            assert loaded.policy.features_extractor.scale == 0.25
        else:
            assert th.equal(trained.q_net(x), loaded.q_net(x))


def test_masked_paper_policy_acts_legally(tmp_path):
    cfg = tiny("maskable_ppo", total_steps=256)
    train(cfg, tmp_path / "run", log=quiet)
    model, _ = load_run(tmp_path / "run")
    env = PaperAssemblyEnv("E1S1", mask_blocked_moves=True)
    policy = PaperModelPolicy(model, env)
    assert policy.masked
    obs, _ = env.reset(seed=11)
    masked_somewhere = False
    for _ in range(env.scenario.step_limit):
        mask = env.action_masks().astype(bool)
        masked_somewhere |= not mask.all()
        action = policy(obs)
        assert mask[action], f"action {action} is masked ({mask})"
        obs, _, term, trunc, _ = env.step(action)
        if term or trunc:
            break
    assert masked_somewhere, "the episode never masked a move: the check proved nothing"


def test_shared_policy_acts_legally(tmp_path):
    cfg = tiny("multi_maskable_ppo", total_steps=256)
    train(cfg, tmp_path / "run", log=quiet)
    model, _ = load_run(tmp_path / "run")
    env = MultiCraneEnv("e1s1", n_cranes=2, max_steps=40)
    policy = SharedModelPolicy(model, env)
    assert policy.masked
    observations, _ = env.reset(seed=3)
    while True:
        actions = policy(observations)
        assert set(actions) == set(env.possible_agents)
        for agent, action in actions.items():
            mask = observations[agent]["action_mask"]
            assert mask[action], f"{agent}: action {action} is masked"
        last = observations
        observations, _, terms, truncs, _ = env.step(actions)
        if any(terms.values()) or any(truncs.values()):
            break
    # The wrapper hands the observations' masks to the model: a mask that allows only
    # `wait` (6) forces it, whatever the network prefers.
    only_wait = {
        a: {"observation": o["observation"], "action_mask": np.eye(len(o["action_mask"]))[6]}
        for a, o in last.items()
    }
    assert policy(only_wait) == dict.fromkeys(env.possible_agents, 6)


# -- 6. run directories ------------------------------------------------------------------------


def test_finished_run_is_not_retrained(references, monkeypatch):
    cfg, run_dir, result = references.get("ppo")
    stamp = (run_dir / "model.zip").stat().st_mtime_ns
    stored = (run_dir / "result.json").read_text()

    def no_training(*args, **kwargs):
        raise AssertionError("a finished run was trained again")

    monkeypatch.setattr(trainer, "make_model", no_training)
    monkeypatch.setattr(trainer, "make_vec_env", no_training)
    start = time.perf_counter()
    again = train(cfg, run_dir, log=quiet)
    assert time.perf_counter() - start < 5
    assert again == json.loads(stored) == json.loads(json.dumps(result))
    assert (run_dir / "model.zip").stat().st_mtime_ns == stamp
    assert (run_dir / "result.json").read_text() == stored


@pytest.mark.parametrize(
    ("change", "key"),
    [
        ({"seed": 5}, "seed"),
        ({"total_steps": 1000}, "total_steps"),
        ({"hyperparams": {**PPO_HP, "n_epochs": 3}}, "hyperparams"),
        ({"algo": "a2c", "hyperparams": {}}, "algo"),
    ],
)
def test_directory_of_another_configuration(change, key, references):
    cfg, run_dir, _ = references.get("ppo")
    config_text = (run_dir / "config.json").read_text()
    other = dataclasses.replace(cfg, **change)
    with pytest.raises(ConfigError, match=key) as info:
        train(other, run_dir, log=quiet)
    assert str(run_dir) in str(info.value)
    assert (run_dir / "config.json").read_text() == config_text


# -- 7. CraneVecEnv --------------------------------------------------------------------------------


def _e1s1(max_steps: int | None = None):
    return lambda: multicrane.parallel_env("e1s1", n_cranes=2, max_steps=max_steps)


def _legal_actions(masks: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    return np.array([random_legal_action(row, rng) for row in masks])


@pytest.mark.parametrize("scenario", ["e1s1", "hall-4c"])
def test_crane_vec_env_seeds(scenario):
    n_copies = 3
    venv = CraneVecEnv(lambda: multicrane.parallel_env(scenario, n_cranes=2), n_copies)
    n = venv.n_agents
    assert venv.num_envs == n_copies * n

    def reset(seed):
        venv.seed(seed)
        return venv.reset()

    first = reset(0)
    copies = [first[c * n] for c in range(n_copies)]
    for a in range(n_copies):
        for b in range(a + 1, n_copies):
            assert not np.array_equal(copies[a], copies[b]), f"copies {a} and {b} start alike"
    assert np.array_equal(reset(0), first)
    other = reset(1)
    assert not np.array_equal(other, first)
    # Not SB3's seed + i: copy 1 of seed 0 is not copy 0 of seed 1.
    assert not np.array_equal(first[n], other[0])
    # A fresh vector environment with the same seed starts the same.
    twin = CraneVecEnv(lambda: multicrane.parallel_env(scenario, n_cranes=2), n_copies)
    twin.seed(0)
    assert np.array_equal(twin.reset(), first)


def test_seeded_dummy_vec_env_seeds():
    venv = SeededDummyVecEnv([lambda: PaperAssemblyEnv("E1S1")] * 3)
    venv.seed(0)
    first = venv.reset()
    assert not np.array_equal(first[0], first[1]) and not np.array_equal(first[1], first[2])
    venv.seed(0)
    assert np.array_equal(venv.reset(), first)
    venv.seed(1)
    other = venv.reset()
    assert not np.array_equal(other, first)
    assert not np.array_equal(first[1], other[0])


def test_crane_vec_env_rows_are_copy_major():
    n_copies = 2
    venv = CraneVecEnv(_e1s1(), n_copies)
    seeds = list(venv.seed(3))  # seed() hands back its own list, emptied by reset()
    assert seeds == copy_seeds(3, n_copies)
    obs = venv.reset()
    refs = [MultiCraneEnv("e1s1", n_cranes=2) for _ in range(n_copies)]
    agents = refs[0].possible_agents
    ref_obs = [env.reset(seed=s)[0] for env, s in zip(refs, seeds, strict=True)]
    rng = np.random.default_rng(0)
    cranes_differ = False
    for _ in range(12):
        for c in range(n_copies):
            for j, agent in enumerate(agents):
                row = c * len(agents) + j
                assert np.array_equal(obs[row], ref_obs[c][agent]["observation"]), row
        cranes_differ |= not np.array_equal(obs[0], obs[1])
        actions = _legal_actions(venv.action_masks(), rng)
        obs, rewards, dones, _ = venv.step(actions)
        for c, env in enumerate(refs):
            joint = {a: int(actions[c * len(agents) + j]) for j, a in enumerate(agents)}
            ref_obs[c], team, _, _, _ = env.step(joint)
            assert np.all(rewards[c * len(agents) : (c + 1) * len(agents)] == team[agents[0]])
        assert not dones.any()
    assert cranes_differ, "the two cranes of a copy never saw different observations"


def test_crane_vec_env_truncation_and_episode_info():
    limit, n_copies = 5, 2
    venv = CraneVecEnv(_e1s1(max_steps=limit), n_copies)
    seeds = list(venv.seed(0))
    venv.reset()
    refs = [MultiCraneEnv("e1s1", n_cranes=2, max_steps=limit) for _ in range(n_copies)]
    agents = refs[0].possible_agents
    for env, s in zip(refs, seeds, strict=True):
        env.reset(seed=s)
    rng = np.random.default_rng(1)
    returns = np.zeros(n_copies)
    for t in range(limit):
        actions = _legal_actions(venv.action_masks(), rng)
        obs, rewards, dones, infos = venv.step(actions)
        terminal = []
        for c, env in enumerate(refs):
            joint = {a: int(actions[c * len(agents) + j]) for j, a in enumerate(agents)}
            ref_obs, team, _, truncs, _ = env.step(joint)
            returns[c] += team[agents[0]]
            terminal.append(ref_obs)
            assert truncs[agents[0]] == (t == limit - 1)
        if t < limit - 1:
            assert not dones.any()
            assert all("terminal_observation" not in i for i in infos)
            continue
        assert dones.all()
        for c, env in enumerate(refs):
            next_obs, _ = env.reset()  # the copy continues its own generator
            for j, agent in enumerate(agents):
                row = c * len(agents) + j
                info = infos[row]
                assert info["TimeLimit.truncated"] is True
                assert info["is_success"] is False
                assert info["episode"]["l"] == limit
                assert info["episode"]["r"] == pytest.approx(returns[c])
                assert np.array_equal(
                    info["terminal_observation"], terminal[c][agent]["observation"]
                )
                assert np.array_equal(obs[row], next_obs[agent]["observation"])
    # after the automatic reset, stepping goes on normally
    _, _, dones, _ = venv.step(_legal_actions(venv.action_masks(), rng))
    assert not dones.any()


def test_crane_vec_env_masks():
    venv = CraneVecEnv(_e1s1(max_steps=6), 2)
    venv.seed(2)
    venv.reset()
    rng = np.random.default_rng(3)
    n = venv.n_agents
    some_masked = False
    for _ in range(9):
        masks = venv.action_masks()
        from_method = np.stack(venv.env_method("action_masks"))
        assert masks.dtype == bool and masks.shape == (venv.num_envs, venv.action_space.n)
        assert np.array_equal(from_method, masks)
        for row in range(venv.num_envs):
            own = venv.envs[row // n].action_masks()[venv.agents[row % n]]
            assert np.array_equal(masks[row], own.astype(bool))
        assert masks.any(axis=1).all()
        some_masked |= not masks.all()
        assert np.array_equal(
            np.stack(venv.env_method("action_masks", indices=[1, 2])), masks[[1, 2]]
        )
        venv.step(_legal_actions(masks, rng))
    assert some_masked


def test_crane_vec_env_state_round_trip():
    venv = CraneVecEnv(_e1s1(max_steps=5), 2)
    venv.seed(4)
    venv.reset()
    warmup = np.random.default_rng(0)
    for _ in range(3):
        venv.step(_legal_actions(venv.action_masks(), warmup))
    state = venv.get_state()

    def continuation():
        rng = np.random.default_rng(9)
        out = []
        for _ in range(8):  # crosses an episode end and an automatic reset
            obs, rewards, dones, infos = venv.step(_legal_actions(venv.action_masks(), rng))
            ends = [
                (i["episode"]["r"], i["episode"]["l"], i["terminal_observation"].copy())
                for i in infos
                if "episode" in i
            ]
            out.append((obs, rewards, dones, venv.action_masks(), ends))
        return out

    first = continuation()
    assert any(step[2].any() for step in first), "no episode ended: the check is too short"
    venv.set_state(state)
    second = continuation()
    for a, b in zip(first, second, strict=True):
        for x, y in zip(a[:4], b[:4], strict=True):
            assert np.array_equal(x, y)
        assert len(a[4]) == len(b[4])
        for (r1, l1, o1), (r2, l2, o2) in zip(a[4], b[4], strict=True):
            assert (r1, l1) == (r2, l2) and np.array_equal(o1, o2)


# -- 8. the plain SuperSuit recipe -------------------------------------------------------------


def test_plain_supersuit_recipe_trains():
    ss = pytest.importorskip("supersuit")
    from stable_baselines3 import PPO

    env = multicrane.parallel_env("e1s1", n_cranes=2, max_steps=16)
    venv = ss.pettingzoo_env_to_vec_env_v1(env)
    venv = ss.concat_vec_envs_v1(venv, 2, num_cpus=0, base_class="stable_baselines3")
    assert venv.num_envs == 4  # 2 copies x 2 cranes
    assert isinstance(venv.observation_space, gym.spaces.Dict)
    assert set(venv.observation_space.spaces) == {"observation", "action_mask"}
    # The observation is a Dict, so SB3 wants MultiInputPolicy; MlpPolicy is refused.
    with pytest.raises(ValueError, match="MultiInputPolicy"):
        PPO("MlpPolicy", venv)
    model = PPO("MultiInputPolicy", venv, n_steps=32, batch_size=64, n_epochs=1, verbose=0)
    budget = 256
    model.learn(budget)  # 64 joint steps per copy: several episodes of 16 steps
    assert model.num_timesteps >= budget
    obs = venv.reset()
    actions, _ = model.predict(obs, deterministic=True)
    assert actions.shape == (4,)
    assert all(0 <= a < env.action_space("crane_0").n for a in actions)
    venv.close()


# -- 9. configuration checks ---------------------------------------------------------------------


def test_config_validation():
    with pytest.raises(ConfigError, match="sac"):
        TrainConfig("E1S1", algo="sac")
    with pytest.raises(ConfigError, match="dqn"):
        TrainConfig("e1s1", paper=False, algo="dqn")  # DQN is paper mode only
    with pytest.raises(ConfigError, match="foo"):
        TrainConfig("E1S1", algo="ppo", hyperparams={"foo": 1})
    with pytest.raises(ConfigError, match="buffer_size"):
        TrainConfig("E1S1", algo="ppo", hyperparams={"buffer_size": 10})  # a DQN setting
    with pytest.raises(ConfigError, match="seed"):
        TrainConfig("E1S1", algo="dqn", hyperparams={"seed": 3})  # a field of its own
    with pytest.raises(ConfigError, match="hall-4c"):
        TrainConfig("hall-4c", paper=True)
    with pytest.raises(ConfigError, match="n_cranes"):
        TrainConfig("E1S1", paper=True, n_cranes=2)
    for bad in (-5, 0):
        with pytest.raises(ConfigError, match="total_steps"):
            TrainConfig("E1S1", total_steps=bad)
    with pytest.raises(ConfigError, match="seed"):
        TrainConfig("E1S1", seed=-1)
    with pytest.raises(ConfigError, match="eval_episodes"):
        TrainConfig("E1S1", eval_episodes=0)
    with pytest.raises(ConfigError, match="n_envs"):
        TrainConfig("E1S1", n_envs=0)
    with pytest.raises(ConfigError, match="colour"):
        TrainConfig.from_dict({"scenario": "E1S1", "colour": "red"})
    # valid ones pass and keep their overrides
    cfg = TrainConfig("e1s1", algo="dqn", hyperparams={"learning_rate": 1e-3})
    assert cfg.scenario == "E1S1" and cfg.hyperparams == {"learning_rate": 1e-3}
    assert TrainConfig.from_dict(cfg.to_dict()) == cfg
    multi = TrainConfig("hall-4c", paper=False, n_cranes=2, algo="maskable_ppo")
    assert multi.name == "hall-4c-2c-maskable_ppo-s0"


def test_config_round_trip(tmp_path):
    cfg = tiny("multi_ppo")
    cfg.save(tmp_path / "config.json")
    assert TrainConfig.load(tmp_path / "config.json") == cfg
    (tmp_path / "bad.json").write_text("[1, 2]")
    with pytest.raises(ConfigError):
        TrainConfig.load(tmp_path / "bad.json")
    with pytest.raises(ConfigError):
        TrainConfig.load(tmp_path / "missing.json")


# -- 10. the command line ------------------------------------------------------------------------


@pytest.fixture
def cli():
    from multicrane.cli import main

    yield lambda argv: main(["train", *argv])


def test_cli_trains_and_reports(cli, tmp_path, capsys):
    out = tmp_path / "run"
    argv = ["--paper", "E1S1", "--algo", "a2c", "--steps", "200", "--envs", "2"]
    argv += ["--eval-episodes", "2", "--no-progress", "--out", str(out)]
    argv += ["--set", "learning_rate=1e-3"]
    assert cli(argv) == 0
    printed = capsys.readouterr().out
    assert "final evaluation (2 episodes, greedy actions)" in printed
    assert "optimal" in printed and "gap" in printed
    result = json.loads((out / "result.json").read_text())
    assert result["steps"] >= 200
    assert result["config"]["algo"] == "a2c"
    assert result["config"]["hyperparams"] == {"learning_rate": 1e-3}
    assert result["hyperparameters"]["learning_rate"] == 1e-3
    assert (out / "model.zip").is_file()
    # the same command again reports the finished run
    assert cli(argv) == 0
    assert "final evaluation" in capsys.readouterr().out


def test_cli_rejects_bad_settings(cli, tmp_path, capsys):
    out = tmp_path / "run"
    assert cli(["--paper", "E1S1", "--set", "foo=1", "--no-progress", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "foo" in err
    assert not out.exists()
    assert cli(["--paper", "hall-4c", "--no-progress", "--out", str(out)]) == 2
    assert "hall-4c" in capsys.readouterr().err
    assert cli(["--paper", "E1S1", "--steps", "-3", "--no-progress", "--out", str(out)]) == 2
    assert "total_steps" in capsys.readouterr().err


# -- 11. the real signal path --------------------------------------------------------------------


@pytest.mark.long
def test_cli_sigint_checkpoints_and_resumes(tmp_path):
    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "multicrane", "train", "--paper", "E1S1", "--algo", "ppo"]
    cmd += ["--steps", "5000", "--envs", "2", "--eval-episodes", "2", "--set", "n_epochs=1"]
    cmd += ["--no-progress", "--checkpoint-every", "0", "--out", str(out)]
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    proc = subprocess.Popen(
        cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True
    )
    try:
        deadline = time.monotonic() + 60
        # tb/ appears when learning starts, inside the signal handlers' scope
        while not (out / "tb").exists():
            assert proc.poll() is None, proc.communicate()[0]
            assert time.monotonic() < deadline, "training never started"
            time.sleep(0.05)
        time.sleep(0.2)
        proc.send_signal(signal.SIGINT)
        output, _ = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130, output
    assert "interrupted" in output
    steps = int((out / "checkpoint" / "steps.txt").read_text())
    assert 0 <= steps < 5000
    assert steps % (125 * 2) == 0  # an update boundary
    assert not (out / "result.json").exists()

    again = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=120)
    assert again.returncode == 0, again.stdout + again.stderr
    assert f"resuming at step {steps}" in again.stdout
    assert "final evaluation" in again.stdout
    result = json.loads((out / "result.json").read_text())
    assert result["sessions"] == 2
    assert result["steps"] == math.ceil(5000 / 250) * 250
    assert not (out / "checkpoint").exists()

    # The resumed run (two processes) learned what one uninterrupted run learns.
    cfg = TrainConfig.load(out / "config.json")
    assert cfg.hyperparams == {"n_epochs": 1} and cfg.total_steps == 5000
    reference = train(cfg, tmp_path / "reference", log=quiet)
    assert reference["steps"] == result["steps"]
    assert state_dicts_equal(final_model(out), final_model(tmp_path / "reference"))


@pytest.mark.parametrize("policy", ["mlp", "set"])
def test_shaping_gamma_sets_the_shaping_discount_of_every_vector_env(policy):
    from multicrane.training.algorithms import algorithm

    cfg = TrainConfig(scenario="e2s2", paper=False, algo="maskable_ppo", n_cranes=2,
                      decisions="task", policy=policy, n_envs=1, shaping_gamma=1.0)  # fmt: skip
    venv = trainer.make_vec_env(cfg, algorithm("maskable_ppo", False), {"gamma": 0.9})
    assert venv.gamma == 1.0  # not the learner's 0.9, and not ignored by the set policy
