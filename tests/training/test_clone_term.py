"""The cloning term of PPO after imitation (``multicrane.training.clone_term``): weight 0
changes nothing, a weight above 0 keeps the policy nearer the teacher's rows, a run with it
resumes exactly, and bad settings are refused with a ``ConfigError``."""

from __future__ import annotations

import numpy as np
import pytest
import torch as th
from conftest import one_torch_thread  # noqa: F401 (fixture)

import policies
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.training import ConfigError, TrainConfig, train
from multicrane.training.clone_term import CloneTerm, cloning_nll, demonstration_rows
from multicrane.training.imitation import Demonstrations, demonstrate
from multicrane.training.model_policy import load_run
from multicrane.training.set_obs import SetLimits
from multicrane.training.set_training import make_set_model, set_hyperparameters
from multicrane.training.set_vec_env import SetVecEnv

pytestmark = pytest.mark.usefixtures("one_torch_thread")

PPO = {"n_steps": 16, "batch_size": 16, "n_epochs": 2, "learning_rate": 1e-3}


def _venv(copies=2):
    make = lambda i: MultiCraneEnv("e3s3", n_cranes=2, decisions="task", reward="makespan")  # noqa: E731
    return SetVecEnv(make, copies, SetLimits.of(make(0).observation_layout), 0.0, 1.0)


@pytest.fixture(scope="module")
def demos():
    venv = _venv()
    venv.seed(3)
    rows = demonstrate(venv, policies.factory("prioritized"), 4, gamma=0.99)
    venv.close()
    return rows


def _learn(demos, weight=None, steps=256):
    """A fresh model trained ``steps`` crane decisions, with the cloning term at ``weight``
    (None: without it); its policy and the term's summary."""
    venv = _venv()
    model = make_set_model(venv, 5, set_hyperparameters(PPO), None)
    summary: dict = {}
    callback = None if weight is None else CloneTerm(demos, weight, 5, summary)
    model.learn(steps, callback=callback)
    venv.close()
    return model.policy, summary


def test_weight_zero_changes_nothing(demos):
    without, _ = _learn(demos)
    with_term, summary = _learn(demos, weight=0.0)
    a, b = without.state_dict(), with_term.state_dict()
    assert all(th.equal(a[k], b[k]) for k in a)
    assert summary["nll"] == []  # no cloning step taken


def test_a_weight_lowers_the_cloning_loss_on_the_teachers_rows(demos):
    plain, _ = _learn(demos)
    cloned, summary = _learn(demos, weight=1.0)
    updates = 256 // (PPO["n_steps"] * 2 * 2)  # decisions per rollout: rounds x copies x cranes
    assert len(summary["nll"]) == updates  # one entry per PPO update, the last one included
    assert cloning_nll(cloned, demos) < cloning_nll(plain, demos) - 0.03
    assert summary["nll"][-1] < summary["nll"][0]


def _cfg(demos_path, steps=256, weight=1.0, **kw):
    return TrainConfig("e3s2", paper=False, n_cranes=2, decisions="task", algo="maskable_ppo",
                       policy="set", imitate="prioritized", imitate_episodes=4,
                       imitate_epochs=2, reward="makespan", shaping=0.0, n_envs=2,
                       total_steps=steps, eval_every=0, eval_episodes=1, checkpoint_every=0,
                       imitate_demos=demos_path, clone_weight=weight,
                       hyperparams=PPO, **kw)  # fmt: skip


def test_a_run_with_the_term_resumes_exactly(tmp_path):
    cfg = _cfg(str(tmp_path / "demos.npz"))
    teacher = policies.factory("prioritized")
    ref = train(cfg, tmp_path / "ref", teacher=teacher, log=lambda *a: None)
    assert ref["clone"]["weight"] == 1.0 and len(ref["clone"]["nll"]) == 4
    assert train(cfg, tmp_path / "cut", teacher=teacher, stop_at=128, log=lambda *a: None) is None
    resumed = train(cfg, tmp_path / "cut", teacher=teacher, log=lambda *a: None)
    assert resumed["clone"]["nll"] == ref["clone"]["nll"]
    a, _ = load_run(tmp_path / "ref")
    b, _ = load_run(tmp_path / "cut")
    sa, sb = a.policy.state_dict(), b.policy.state_dict()
    assert all(th.equal(sa[k], sb[k]) for k in sa)
    # The file's rows are the ones the term reads; another setting's file is refused.
    assert len(demonstration_rows(cfg).actions) == ref["imitation"]["rows"]
    with pytest.raises(ConfigError, match="episodes: file 4 != run 5"):
        demonstration_rows(TrainConfig.from_dict({**cfg.to_dict(), "imitate_episodes": 5}))


def test_bad_settings_are_refused(tmp_path):
    for weight in (-1.0, float("nan"), float("inf"), True, "1"):
        with pytest.raises(ConfigError, match="clone_weight=.*must be a finite number >= 0"):
            _cfg(str(tmp_path / "d.npz"), weight=weight)
    with pytest.raises(ConfigError, match="clone_weight=1.0: needs imitate "):
        TrainConfig("e3s2", paper=False, n_cranes=2, decisions="task", algo="maskable_ppo",
                    policy="set", clone_weight=1.0)  # fmt: skip
    with pytest.raises(ConfigError, match="clone_weight=0.5: needs imitate_demos"):
        _cfg(None, weight=0.5)
    assert _cfg(None, weight=0.0).clone_weight == 0.0  # weight 0 needs nothing
    with pytest.raises(ConfigError, match="no demonstrations to clone"):
        demonstration_rows(_cfg(str(tmp_path / "missing.npz")))
    one = np.zeros((3, 5), dtype=bool)
    one[:, 0] = True  # one allowed action per row: nothing to choose, nothing to clone
    empty = Demonstrations(np.zeros((3, 4), np.float32), one, np.zeros(3, np.int64),
                           np.zeros(3, np.float32), [1])  # fmt: skip
    with pytest.raises(ConfigError, match="no row with a choice"):
        CloneTerm(empty, 1.0, 0, {})
