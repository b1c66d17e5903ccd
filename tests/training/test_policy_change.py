"""``train/policy_kl``: the KL between the whole masked policies before and after each PPO
update, on the update's own states; it changes nothing the learner does. With a limit, an
update past it is made again smaller or left out, and a limit never passed changes nothing."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("sb3_contrib")

import torch as th  # noqa: E402
from stable_baselines3.common.callbacks import BaseCallback, CallbackList  # noqa: E402
from stable_baselines3.common.logger import KVWriter, Logger  # noqa: E402

from multicrane.envs.crane_env import MultiCraneEnv  # noqa: E402
from multicrane.training.algorithms import algorithm  # noqa: E402
from multicrane.training.policy_change import (  # noqa: E402
    PolicyChange,
    checked_max_kl,
    with_policy_change,
)
from multicrane.training.set_obs import SetLimits  # noqa: E402
from multicrane.training.set_training import make_set_model, set_hyperparameters  # noqa: E402
from multicrane.training.set_vec_env import SetVecEnv  # noqa: E402

pytestmark = pytest.mark.usefixtures("one_torch_thread")


class _Kept(KVWriter):
    def __init__(self):
        self.dumps = []

    def write(self, key_values, key_excluded, step=0):
        self.dumps.append(dict(key_values))


class _Idle(BaseCallback):
    def _on_step(self) -> bool:
        return True


def _learn(with_change: bool, learning_rate=1e-3, max_kl=None):
    env = MultiCraneEnv("e2s2", n_cranes=2, decisions="task")
    venv = SetVecEnv(lambda i: MultiCraneEnv("e2s2", n_cranes=2, decisions="task"), 2,
                     SetLimits.of(env.observation_layout))  # fmt: skip
    hp = set_hyperparameters({"n_steps": 16, "batch_size": 32, "learning_rate": learning_rate})
    model = make_set_model(venv, 0, hp, None)
    model.policy.claim_rows = venv.n_agents
    kept = _Kept()
    model.set_logger(Logger(folder=None, output_formats=[kept]))
    callback = with_policy_change(model, _Idle(), max_kl) if with_change else _Idle()
    model.learn(3 * 16 * venv.num_envs, callback=callback)
    return model, kept.dumps


def test_the_run_learns_the_same_parameters_and_logs_the_change():
    plain, dumps_plain = _learn(False)
    watched, dumps = _learn(True)
    a, b = plain.policy.state_dict(), watched.policy.state_dict()
    assert a.keys() == b.keys() and all(th.equal(a[k], b[k]) for k in a)
    assert not any("train/policy_kl" in d for d in dumps_plain)
    kls = [d["train/policy_kl"] for d in dumps if "train/policy_kl" in d]
    assert len(kls) == 2 and all(np.isfinite(k) and k > 0 for k in kls)  # updates 1 and 2


def test_no_update_no_change():
    _, dumps = _learn(True, learning_rate=0.0)
    kls = [d["train/policy_kl"] for d in dumps if "train/policy_kl" in d]
    assert kls and all(k == 0.0 for k in kls)


def test_which_learners_get_it():
    from stable_baselines3 import DQN, PPO

    from multicrane.envs.paper_env import PaperAssemblyEnv

    env = PaperAssemblyEnv("E1S1")
    idle = _Idle()
    added = with_policy_change(PPO("MlpPolicy", env, n_steps=8, batch_size=8), idle)
    assert isinstance(added, CallbackList)
    assert [type(c) for c in added.callbacks] == [PolicyChange, _Idle]
    assert with_policy_change(DQN("MlpPolicy", env), idle) is idle


def _same(a, b) -> bool:
    a, b = a.policy.state_dict(), b.policy.state_dict()
    return a.keys() == b.keys() and all(th.equal(a[k], b[k]) for k in a)


def test_a_limit_never_passed_changes_nothing():
    plain, _ = _learn(False)
    limited, dumps = _learn(True, max_kl=1e9)
    assert _same(plain, limited)
    assert not any("train/updates_backtracked" in d for d in dumps)


def test_updates_past_the_limit_are_made_smaller_or_left_out():
    start, _ = _learn(True, learning_rate=0.0)  # the initial parameters, never moved
    frozen, dumps = _learn(True, max_kl=1e-12)  # every try passes: every update left out
    assert _same(start, frozen)
    assert [d["train/updates_rejected"] for d in dumps if "train/updates_rejected" in d] == [1, 2]
    assert all(d["train/policy_kl"] == 0.0 for d in dumps if "train/policy_kl" in d)
    _, free = _learn(True)
    first = [d["train/policy_kl"] for d in free if "train/policy_kl" in d][0]
    limit = first / 3  # the first update passes it; half or a quarter of the rate may not
    limited, dumps = _learn(True, max_kl=limit)
    assert dumps[1]["train/policy_kl_rejected"] == pytest.approx(first)
    kept = [d["train/policy_kl"] for d in dumps if "train/policy_kl" in d]
    assert all(k <= limit for k in kept) and kept[0] > 0  # made smaller, not left out
    assert dumps[1]["train/updates_backtracked"] == 1


def test_the_limit_is_checked():
    for bad in (0, -0.1, "0.1", True):
        with pytest.raises(ValueError, match="must be a positive number"):
            checked_max_kl(bad, algorithm("maskable_ppo", paper=False))
    with pytest.raises(ValueError, match="DQN is not one of SB3's on-policy learners"):
        checked_max_kl(0.1, algorithm("dqn", paper=True))
    assert checked_max_kl(None, algorithm("dqn", paper=True)) is None
    assert checked_max_kl(1, algorithm("ppo", paper=True)) == 1.0


def test_the_set_policy_trains_with_the_limit_unless_turned_off(tmp_path):
    from multicrane.training import TrainConfig
    from multicrane.training.set_training import SET_PPO
    from multicrane.training.trainer import Run

    def run(**hyperparams):
        cfg = TrainConfig("e2s2", paper=False, n_cranes=2, decisions="task",
                          algo="maskable_ppo", policy="set", hyperparams=hyperparams)  # fmt: skip
        return Run(cfg, tmp_path / str(len(hyperparams)))

    assert run().max_policy_kl == SET_PPO["max_policy_kl"] == 0.1
    assert run(max_policy_kl=None).max_policy_kl is None
    assert "max_policy_kl" not in run().params  # the callback's, not the learner's
