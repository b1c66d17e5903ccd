"""The convolutional features extractor over the paper's observation grid (``GridCNN``)."""

from __future__ import annotations

import numpy as np
import pytest
import torch as th
from gymnasium import spaces

from multicrane.envs.paper_env import PaperAssemblyEnv
from multicrane.training import TrainConfig, load_run, train
from multicrane.training.algorithms import ScaledFlatten, algorithm, hyperparameters
from multicrane.training.grid_cnn import GridCNN, features_extractor, grid_shape

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def test_the_grid_is_the_papers_plan_in_channel_x_y_order():
    """A number at (x, y, c) of the flat observation lands at [c, x, y] of the convolved grid."""
    env = PaperAssemblyEnv("E1S1")
    assert grid_shape(env.observation_space) == env.plan_shape == (15, 15, 6)
    net = GridCNN(env.observation_space, scale=0.5)
    seen = {}
    net.conv[0].register_forward_hook(lambda m, inp, out: seen.update(grid=inp[0]))
    for x, y, c in [(0, 0, 0), (3, 11, 2), (14, 7, 5)]:
        obs = np.zeros((1, *env.plan_shape), np.float32)
        obs[0, x, y, c] = 4.0
        net(th.as_tensor(obs.reshape(1, -1)))
        grid = seen["grid"]
        assert grid.shape == (1, 6, 15, 15)
        assert grid[0, c, x, y] == 2.0 and float(grid.sum()) == 2.0  # scaled, nowhere else


def test_a_batch_of_observations_gives_one_feature_row_each():
    env = PaperAssemblyEnv("E3S1")
    obs = np.stack([env.reset(seed=s)[0] for s in range(3)])
    out = GridCNN(env.observation_space, features_dim=32)(th.as_tensor(obs))
    assert out.shape == (3, 32) and bool(th.isfinite(out).all())


@pytest.mark.parametrize(
    "space", [spaces.Box(0, 1, (1351,)), spaces.Box(0, 1, (15, 90)), spaces.Discrete(3)]
)
def test_a_space_that_is_no_square_grid_is_refused_by_shape(space):
    with pytest.raises(ValueError, match="grid_cnn needs"):
        grid_shape(space)


def test_the_features_setting_names_the_extractor():
    algo = algorithm("maskable_ppo", True)
    assert hyperparameters(algo, "E1S1", {"features": "grid_cnn"})["features"] == "grid_cnn"
    assert features_extractor("flat") is None and features_extractor("grid_cnn") is GridCNN
    with pytest.raises(ValueError, match="features='cnn': one of flat, grid_cnn"):
        hyperparameters(algo, "E1S1", {"features": "cnn"})
    with pytest.raises(Exception, match="features='cnn'"):
        TrainConfig("E1S1", paper=True, algo="maskable_ppo", hyperparams={"features": "cnn"})


def test_a_run_with_it_round_trips_and_resumes_exactly(tmp_path):
    """The setting is stored in config.json; a resumed run equals an uninterrupted one."""
    cfg = TrainConfig("E1S1", paper=True, algo="maskable_ppo", total_steps=384, n_envs=2,
                      hyperparams={"n_steps": 64, "batch_size": 64, "n_epochs": 1,
                                   "features": "grid_cnn"},
                      eval_episodes=1, checkpoint_every=0, shaping=1.0)  # fmt: skip
    cfg.save(tmp_path / "config.json")
    assert TrainConfig.load(tmp_path / "config.json").differences(cfg) == []
    train(cfg, tmp_path / "whole", log=lambda *a: None)
    assert train(cfg, tmp_path / "cut", stop_at=150, log=lambda *a: None) is None
    train(cfg, tmp_path / "cut", log=lambda *a: None)
    (a, *_), (b, *_) = (load_run(tmp_path / d) for d in ("whole", "cut"))
    assert isinstance(a.policy.features_extractor, GridCNN)
    sa, sb = a.policy.state_dict(), b.policy.state_dict()
    assert sa.keys() == sb.keys() and all(th.equal(sa[k], sb[k]) for k in sa)
    flat = TrainConfig("E1S1", paper=True, algo="maskable_ppo", total_steps=128, n_envs=2,
                       hyperparams={"n_steps": 64, "batch_size": 64, "n_epochs": 1},
                       eval_episodes=1, checkpoint_every=0)  # fmt: skip
    train(flat, tmp_path / "flat", log=lambda *a: None)
    assert isinstance(load_run(tmp_path / "flat")[0].policy.features_extractor, ScaledFlatten)
