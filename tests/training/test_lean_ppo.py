"""The lean PPO (issue 32): GAE, masks, truncation bootstrap, determinism, exact resume,
learning, and its place in ``multicrane train`` / ``multicrane evaluate``."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import torch as th  # noqa: E402
from gymnasium import spaces  # noqa: E402

from multicrane.training import TrainConfig, train  # noqa: E402
from multicrane.training.lean_ppo import LeanPPO, default_hyperparameters  # noqa: E402
from multicrane.training.lean_ppo_buffer import compute_gae  # noqa: E402
from multicrane.training.lean_ppo_env import LeanVecEnv  # noqa: E402
from multicrane.training.lean_ppo_net import MASKED_LOGIT, sample, sparse  # noqa: E402
from multicrane.training.model_policy import load_run  # noqa: E402

SMALL = {"n_steps": 8, "batch_size": 32, "n_epochs": 2}  # 8 copies: 64 steps per update


pytestmark = pytest.mark.usefixtures("one_torch_thread")


def quiet(*_args) -> None:
    pass


def make_model(env, seed: int = 0, **changes) -> LeanPPO:
    params = {**default_hyperparameters(), **SMALL, **changes}
    kwargs = params.pop("policy_kwargs")
    kwargs["features_extractor_kwargs"] = {"scale": 0.25}
    return LeanPPO("MlpPolicy", env, seed=seed, policy_kwargs=kwargs, **params)


def weights(model) -> dict[str, th.Tensor]:
    return {k: v.clone() for k, v in model.policy.state_dict().items()}


def same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(th.equal(a[k], b[k]) for k in a)


# -- the pieces --------------------------------------------------------------------------------


def test_gae_matches_a_hand_computation():
    """Two copies, three steps; copy 0's episode ends after its second step."""
    gamma, lam = 0.9, 0.8
    rewards = th.tensor([[1.0, 0.0], [2.0, 1.0], [0.5, -1.0]])
    values = th.tensor([[0.5, 0.2], [0.4, 0.1], [0.3, 0.6]])
    dones = th.tensor([[0.0, 0.0], [1.0, 0.0], [0.0, 0.0]])
    last = th.tensor([0.7, -0.2])
    adv, ret = compute_gae(rewards, values, dones, last, gamma, lam)
    # copy 0: step 2 bootstraps from last; step 1 ends its episode; step 0 looks into step 1
    d2 = 0.5 + gamma * 0.7 - 0.3
    d1 = 2.0 - 0.4
    d0 = 1.0 + gamma * 0.4 - 0.5
    a0 = [d0 + gamma * lam * d1, d1, d2]
    # copy 1: no episode end
    e2 = -1.0 + gamma * -0.2 - 0.6
    e1 = 1.0 + gamma * 0.6 - 0.1
    e0 = 0.0 + gamma * 0.1 - 0.2
    a1_2 = e2
    a1_1 = e1 + gamma * lam * a1_2
    a1 = [e0 + gamma * lam * a1_1, a1_1, a1_2]
    expected = th.tensor([a0, a1]).T
    assert th.allclose(adv, expected, atol=1e-6)
    assert th.allclose(ret, expected + values, atol=1e-6)


def test_sparse_input_equals_the_dense_product():
    rng = np.random.default_rng(0)
    obs = (rng.random((5, 40)) < 0.1) * rng.integers(1, 14, (5, 40))
    obs[3] = 0  # a row without a non-zero entry
    x = sparse(obs.astype(np.uint8))
    w = th.randn(40, 3)
    from multicrane.training.lean_ppo_net import SparseLinear

    layer = SparseLinear(40, 3, scale=0.25)
    with th.no_grad():
        layer.weight.copy_(w)
    dense = th.as_tensor(obs, dtype=th.float32) * 0.25 @ w + layer.bias
    assert th.allclose(layer(x), dense, atol=1e-5)
    # and the gradient of the weight is the dense one's
    layer(x).pow(2).sum().backward()
    w2 = w.clone().requires_grad_(True)
    (th.as_tensor(obs, dtype=th.float32) * 0.25 @ w2 + layer.bias.detach()).pow(2).sum().backward()
    assert th.allclose(layer.weight.grad, w2.grad, atol=1e-4)


def test_masked_actions_are_never_sampled():
    gen = th.Generator().manual_seed(0)
    rng = np.random.default_rng(1)
    masks = th.as_tensor(rng.integers(0, 2, (20_000, 6)), dtype=th.int8)
    masks[:, 0] = 1  # at least one allowed action per row
    logits = th.randn(20_000, 6, generator=gen) * 5
    logits = logits.masked_fill(masks == 0, MASKED_LOGIT)
    actions = sample(logits, gen)
    assert bool(masks.gather(1, actions[:, None]).all())
    # and in a rollout on the env's blocked-move masks
    model = make_model(LeanVecEnv("E1S1", 8, mask_blocked_moves=True))
    model.learn(64)
    buf = model.rollout
    assert bool(buf.masks.gather(2, buf.actions[..., None]).all())
    assert not bool(buf.masks.all())  # some moves were blocked


class _Truncating:
    """A stub of ``LeanVecEnv``: two copies; copy 0 is truncated, copy 1 terminates at the
    first step (each with a final observation of its own), rewards 1 and 2."""

    num_envs = 2
    observation_space = spaces.Box(0, 13, (4,), np.uint8)
    action_space = spaces.Discrete(2)

    def __init__(self):
        self.obs = np.array([[1, 0, 0, 2], [0, 3, 0, 0]], dtype=np.uint8)
        self.masks = np.ones((2, 2), dtype=np.int8)
        self.final = np.array([[0, 0, 5, 0], [4, 0, 0, 1]], dtype=np.uint8)

    def reset(self, seed):
        return self.obs, self.masks

    def current(self):
        return self.obs, self.masks

    def step(self, actions):
        done = np.array([True, True])
        return (self.obs, self.masks, np.array([1.0, 2.0]), np.array([False, True]), done,
                self.final, [])  # fmt: skip


def test_truncation_bootstraps_from_the_final_observation():
    model = make_model(_Truncating(), n_steps=1, batch_size=2, learning_rate=0.0)
    model.learn(2)
    gamma = model.settings["gamma"]
    with th.no_grad():
        v_final = model.policy.value(sparse(_Truncating().final))
    buf = model.rollout
    assert buf.rewards[0, 0].item() == pytest.approx(1.0 + gamma * v_final[0].item(), abs=1e-6)
    assert buf.rewards[0, 1].item() == 2.0  # terminated: no bootstrap
    assert buf.dones[0].tolist() == [1.0, 1.0]


# -- determinism and learning ------------------------------------------------------------------


def test_same_seed_same_weights():
    runs = []
    for seed, changes in ((0, {}), (0, {}), (1, {}), (0, {"clip_range_vf": 0.01})):
        model = make_model(LeanVecEnv("E1S1", 8, True), seed=seed, **changes)
        model.learn(192)
        runs.append(weights(model))
    assert same(runs[0], runs[1])
    assert not same(runs[0], runs[2])
    assert not same(runs[0], runs[3])  # the value clipping changes the updates


class _Corridor:
    """A stub of ``LeanVecEnv``: each copy walks a corridor of 10 cells from cell 0 (action
    1: right, 0: left, at most to cell 0); -1 per step, +20 on reaching cell 9 (terminated),
    truncated after 30 steps. The observation is the cell, one-hot. The best return is 12; a
    random walk is mostly truncated (-30)."""

    observation_space = spaces.Box(0, 1, (10,), np.uint8)
    action_space = spaces.Discrete(2)

    def __init__(self, n: int):
        self.num_envs = n
        self.cell = np.zeros(n, dtype=np.int64)
        self.steps = np.zeros(n, dtype=np.int64)
        self.returns = np.zeros(n)
        self.masks = np.ones((n, 2), dtype=np.int8)

    def _obs(self, cells):
        return np.eye(10, dtype=np.uint8)[cells]

    def reset(self, seed):
        return self.current()

    def current(self):
        return self._obs(self.cell), self.masks

    def step(self, actions):
        self.cell = np.clip(self.cell + 2 * actions - 1, 0, 9)
        self.steps += 1
        terminated = self.cell == 9
        truncated = ~terminated & (self.steps >= 30)
        rewards = np.where(terminated, 20.0, -1.0)
        self.returns += rewards
        done = terminated | truncated
        final = self._obs(self.cell)
        episodes = [{"r": r, "l": 0, "success": True} for r in self.returns[done]]
        self.cell[done], self.steps[done], self.returns[done] = 0, 0, 0.0
        return *self.current(), rewards, terminated, truncated, final, episodes


def test_learns_a_tiny_case():
    """A few thousand steps take the corridor's return from a random walk's to the best."""
    model = make_model(_Corridor(32), n_steps=16, batch_size=128, n_epochs=4,
                       learning_rate=3e-3, gamma=0.9)  # fmt: skip
    model.learn(1024)  # every copy's first episode ends within 30 steps
    first = np.mean([e["r"] for e in model.ep_info_buffer])
    model.learn(5_120, reset_num_timesteps=False)
    model.ep_info_buffer.clear()
    model.learn(512, reset_num_timesteps=False)
    last = np.mean([e["r"] for e in model.ep_info_buffer])
    assert first < -15 and last > 11
    assert model.predict(np.eye(10, dtype=np.uint8)[:9])[0].tolist() == [1] * 9


# -- runs: train, resume, evaluate -------------------------------------------------------------


def cfg(**changes) -> TrainConfig:
    kw = dict(scenario="E1S1", algo="lean_ppo", total_steps=256, n_envs=8,
              hyperparams=dict(SMALL), eval_episodes=2, checkpoint_every=64)  # fmt: skip
    return TrainConfig(**{**kw, **changes})


MOTION = dict(scenario="e2s2", paper=False, n_cranes=2, n_envs=4, max_steps=40,
              hyperparams={**SMALL, "policy_kwargs": {"net_arch": [32, 32]}})  # fmt: skip


@pytest.mark.parametrize(
    ("mode", "algorithm"), [("paper", "lean PPO"), ("motion", "lean PPO (shared)")]
)
def test_resume_equals_an_uninterrupted_run(tmp_path, mode, algorithm):
    """Paper mode, and the motion mode's shared policy (4 copies x 2 cranes as 8 rows)."""
    config = cfg() if mode == "paper" else cfg(**MOTION)
    whole = train(config, tmp_path / "whole", log=quiet)
    assert whole["steps"] == 256 and whole["algorithm"] == algorithm
    assert train(config, tmp_path / "cut", stop_at=100, log=quiet) is None
    assert int((tmp_path / "cut" / "checkpoint" / "steps.txt").read_text()) == 128
    resumed = train(config, tmp_path / "cut", log=quiet)
    assert resumed["sessions"] == 2
    a, _ = load_run(tmp_path / "whole")
    b, _ = load_run(tmp_path / "cut")
    assert same(weights(a), weights(b))
    assert [e["return"] for e in resumed["final_episodes"]] == [
        e["return"] for e in whole["final_episodes"]
    ]
    assert list((tmp_path / "whole" / "tb").rglob("events.out.tfevents.*"))


def test_train_and_evaluate_commands(tmp_path, capsys):
    from multicrane.cli import main

    out = tmp_path / "run"
    args = ["train", "--paper", "E1S1", "--algo", "lean_ppo", "--steps", "128", "--envs", "8",
            "--set", "n_steps=8", "--set", "batch_size=32", "--eval-episodes", "2",
            "--no-progress", "--out", str(out)]  # fmt: skip
    assert main(args) == 0
    assert "lean PPO" in capsys.readouterr().out
    assert main(["evaluate", "--paper", "E1S1", "--policy", str(out), "--episodes", "2"]) == 0
    assert "lean_ppo (run)" in capsys.readouterr().out
    assert main(args[:-2] + ["--device", "cpu", "--algo", "ppo", "--out", str(out)]) == 2


def test_refused_settings(tmp_path):
    with pytest.raises(ValueError, match="shaping"):
        train(cfg(shaping=-1.0), tmp_path / "shaped", log=quiet)
    with pytest.raises(ValueError, match="batch_size"):
        make_model(LeanVecEnv("E1S1", 2, True), batch_size=100).learn(16)


def test_training_throughput_figures():
    from multicrane.training.lean_ppo_bench import training_steps_per_second

    wall, cpu = training_steps_per_second("lean_ppo", "E1S1", 1024, n_envs=32)
    assert wall > 0 and cpu > 0
