"""Soft imitation targets (``multicrane.training.soft_targets``): the target of known candidate
makespans, the hard label's loss as the temperature goes to 0, the values kept with the
demonstrations and in their file, and the run option that uses them."""

from __future__ import annotations

import numpy as np
import pytest
import torch as th
from conftest import one_torch_thread  # noqa: F401 (fixture)

import policies
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.training import ConfigError, TrainConfig, train
from multicrane.training.imitation import DemonstrationsError, clone, demonstrate, load, save
from multicrane.training.set_obs import SetLimits
from multicrane.training.set_training import make_set_model, set_hyperparameters
from multicrane.training.set_vec_env import SetVecEnv
from multicrane.training.soft_targets import actor_loss, targets
from policies.lookahead import LookaheadTeacher

pytestmark = pytest.mark.usefixtures("one_torch_thread")
NAN = np.nan


def _venv(name="e3s2", n=2, copies=2):
    make = lambda i: MultiCraneEnv(name, n_cranes=n, decisions="task", reward="makespan")  # noqa: E731
    return SetVecEnv(make, copies, SetLimits.of(make(0).observation_layout), 0.0, 0.99)


def test_soft_target_of_known_candidate_makespans():
    values = np.array([
        [NAN, 10.0, 12.0, NAN, 11.0],  # label 1, the best: softmax(-(v - 10) / tau)
        [14.0, 10.0, NAN, 10.0, NAN],  # label 3: ties with 1 share the weight
        [NAN, NAN, NAN, NAN, NAN],  # no values: the one-hot label
        [NAN, 10.0, 12.0, NAN, NAN],  # its label (4) has no value: the one-hot label
        [NAN, 1e9, 20.0, NAN, NAN],  # an unfinished copy (UNFINISHED) gets no weight
    ], dtype=np.float32)  # fmt: skip
    actions = np.array([1, 3, 0, 4, 2])
    out = targets(values, actions, 5, tau=1.0, wait=True)
    w = np.exp([0.0, -2.0, -1.0])
    assert np.allclose(out[0], [0, w[0], w[1], 0, w[2]] / w.sum())
    e = np.exp(-4.0)
    assert np.allclose(out[1], [e, 1, 0, 1, 0] / (2 + e))
    assert out[2].tolist() == [1, 0, 0, 0, 0] and out[3].tolist() == [0, 0, 0, 0, 1]
    assert out[4].tolist() == [0, 0, 1, 0, 0]
    assert np.allclose(out.sum(1), 1.0)
    # A larger temperature spreads the weight; tau = 0 or no values: every row one-hot.
    assert targets(values, actions, 5, tau=2.0, wait=True)[0, 2] > out[0, 2]
    # By default waiting (action 0) is a target only where it is the label.
    default = targets(values, actions, 5, tau=1.0)
    assert np.allclose(default[1], [0, 0.5, 0, 0.5, 0]) and np.allclose(default[0], out[0])
    waits = np.array([[10.0, 11.0, NAN], [10.0, 10.0, NAN]], dtype=np.float32)
    assert np.allclose(targets(waits, np.array([0, 1]), 3, tau=1.0),
                       [[1 / (1 + np.exp(-1)), np.exp(-1) / (1 + np.exp(-1)), 0], [0, 1, 0]])
    hard = np.eye(5, dtype=np.float32)[actions]
    assert np.array_equal(targets(values, actions, 5, tau=0.0), hard)
    assert np.array_equal(targets(None, actions, 5, tau=1.0), hard)


def test_small_temperature_gives_the_hard_labels_loss():
    venv = _venv()
    venv.seed(0)
    demos = demonstrate(venv, policies.factory("prioritized"), 2, gamma=0.99)
    model = make_set_model(venv, 0, set_hyperparameters({}), None)
    rows = np.flatnonzero(demos.decisions)[:64]
    obs, masks, actions = (th.as_tensor(demos.observations[rows]), demos.masks[rows],
                           demos.actions[rows])  # fmt: skip
    # Made-up candidate values: the label best (100), every other allowed action worse.
    values = np.full(masks.shape, np.nan, dtype=np.float32)
    for k, row in enumerate(masks):
        allowed = np.flatnonzero(row)
        values[k, allowed] = 101.0 + np.arange(len(allowed))
        values[k, actions[k]] = 100.0
    with th.no_grad():
        v_hard, hard = actor_loss(model.policy, obs, actions, masks)  # evaluate_actions
        values_0, at_0 = actor_loss(model.policy, obs, actions, masks,
                                    targets(values, actions, masks.shape[1], 0.0))  # fmt: skip
        _, cold = actor_loss(model.policy, obs, actions, masks,
                             targets(values, actions, masks.shape[1], 1e-3))  # fmt: skip
        _, warm = actor_loss(model.policy, obs, actions, masks,
                             targets(values, actions, masks.shape[1], 2.0))  # fmt: skip
    assert float(at_0) == pytest.approx(float(hard), abs=1e-5)
    assert float(cold) == pytest.approx(float(hard), abs=1e-5)
    assert th.allclose(values_0, v_hard)  # the one-pass critic is the critic
    assert abs(float(warm) - float(hard)) > 1e-2  # a real temperature is another target


def test_lookahead_values_are_kept_and_round_trip(tmp_path):
    venv = _venv("e3s3", copies=1)
    venv.seed(2)
    demos = demonstrate(venv, LookaheadTeacher(), 1, gamma=0.99, values=True)
    assert demos.values.shape == demos.masks.shape
    valued = np.isfinite(demos.values).any(1)
    assert valued.any() and (valued <= demos.decisions).all()  # only rows with a choice
    # Values only for allowed actions; the label is a candidate and finished first.
    assert demos.masks[np.isfinite(demos.values)].all()
    label = demos.values[np.arange(len(demos)), demos.actions]
    assert np.isfinite(label[valued]).all()
    assert (label[valued] == np.nanmin(demos.values[valued], 1)).all()
    assert (np.isfinite(demos.values).sum(1)[valued] >= 2).all()
    meta = {"teacher": "lookahead", "scenario": "e3s3", "episodes": 1, "seed": 5}
    path = tmp_path / "demos.npz"
    save(demos, path, {**meta, "values": "candidate makespans"})
    back = load(path, {**meta, "values": "candidate makespans"})
    np.testing.assert_array_equal(back.values, demos.values)
    assert np.array_equal(back.actions, demos.actions)
    assert load(path, meta).actions.shape == demos.actions.shape  # a hard run may read it
    save(demos.__class__(demos.observations, demos.masks, demos.actions, demos.returns,
                         demos.makespans), path, meta)  # fmt: skip
    assert load(path, meta).values is None
    with pytest.raises(DemonstrationsError, match="values: file None"):
        load(path, {**meta, "values": "candidate makespans"})  # a soft run needs them
    # Fitted on soft targets, the policy moves towards the better candidates.
    model = make_set_model(venv, 0, set_hyperparameters({}), None)
    history = clone(model.policy, demos, epochs=5, batch_size=64, soft=1.0)
    assert history[-1]["actor_nll"] < history[0]["actor_nll"]


def test_soft_imitation_option(tmp_path):
    base = dict(paper=False, n_cranes=2, decisions="task", algo="maskable_ppo", policy="set")
    with pytest.raises(ConfigError, match="imitate_soft=1.0: needs imitate"):
        TrainConfig("e3s2", **base, imitate_soft=1.0)
    with pytest.raises(ConfigError, match="needs imitate='lookahead'"):
        TrainConfig("e3s2", **base, imitate="prioritized", imitate_soft=1.0)
    with pytest.raises(ConfigError, match="must be a temperature >= 0"):
        TrainConfig("e3s2", **base, imitate="lookahead", imitate_soft=-1.0)
    with pytest.raises(ConfigError, match="needs imitate='lookahead'"):
        TrainConfig("e3s2", **base, imitate="prioritized:rank=nearest", imitate_soft=1.0)
    given = TrainConfig("e3s2", **base, imitate="lookahead:candidates=8", imitate_soft=1.0)
    assert given.imitate_soft == 1.0  # the look-ahead with its options values its candidates
    cfg = TrainConfig("e3s3", **base, imitate="lookahead", imitate_soft=1.0, imitate_episodes=1,
                      imitate_epochs=2, reward="makespan", shaping=0.0, n_envs=1,
                      total_steps=16, eval_episodes=1, checkpoint_every=0,
                      imitate_demos=str(tmp_path / "d.npz"),
                      hyperparams={"n_steps": 16, "batch_size": 16, "n_epochs": 1,
                                   "learning_rate": 0.0})  # fmt: skip
    result = train(cfg, tmp_path / "run", teacher=policies.factory("lookahead"),
                   log=lambda *a: None)  # fmt: skip
    imitation = result["imitation"]
    assert imitation["soft_tau"] == 1.0 and 0 < imitation["valued_rows"] <= imitation["rows"]
    with np.load(tmp_path / "d.npz") as data:
        assert "values" in data.files and '"values"' in str(data["meta"])
