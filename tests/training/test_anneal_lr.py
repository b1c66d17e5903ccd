"""``anneal_lr`` for SB3's learners (``algorithms.with_lr_schedule``): the learning rate decays
linearly from its value to 0 over the run's budget, across a resume; off, nothing changes;
the lean PPO keeps its own setting; anything but a bool is refused."""

from __future__ import annotations

import pytest
import torch as th
from conftest import one_torch_thread  # noqa: F401 (fixture)
from sb3_contrib import MaskablePPO
from stable_baselines3 import PPO

from multicrane.training import ConfigError, TrainConfig, train
from multicrane.training.algorithms import with_lr_schedule
from multicrane.training.lean_ppo import LeanPPO
from multicrane.training.model_policy import load_run

pytestmark = pytest.mark.usefixtures("one_torch_thread")


@pytest.mark.parametrize(
    "cls, params, at_start, halfway",
    [
        (MaskablePPO, {"learning_rate": 1e-3, "anneal_lr": True}, 1e-3, 5e-4),
        (PPO, {"anneal_lr": True}, 3e-4, 1.5e-4),  # SB3's own default rate
        (MaskablePPO, {"learning_rate": 1e-3, "anneal_lr": False}, 1e-3, 1e-3),
        (MaskablePPO, {"learning_rate": 1e-3}, 1e-3, 1e-3),
    ],
)
def test_the_schedule_table(cls, params, at_start, halfway):
    built = with_lr_schedule(cls, params)
    assert "anneal_lr" not in built  # ours, not an SB3 setting
    rate = built.get("learning_rate", 3e-4)
    value = (lambda p: rate(p)) if callable(rate) else (lambda p: rate)
    assert value(1.0) == pytest.approx(at_start)
    assert value(0.5) == pytest.approx(halfway)
    if params.get("anneal_lr"):
        assert value(0.0) == 0.0 and value(-0.01) == 0.0  # a budget overrun stays at 0


def test_the_lean_ppo_anneals_by_itself():
    params = {"learning_rate": 1e-3, "anneal_lr": False}
    assert with_lr_schedule(LeanPPO, params) == params


PPO_SETTINGS = {"n_steps": 16, "batch_size": 16, "n_epochs": 2, "learning_rate": 1e-3}


def _cfg(anneal, steps=256):
    hyper = {**PPO_SETTINGS, **({} if anneal is None else {"anneal_lr": anneal})}
    return TrainConfig("e3s2", paper=False, n_cranes=2, decisions="task", algo="maskable_ppo",
                       policy="set", reward="makespan", shaping=0.0, n_envs=2,
                       total_steps=steps, eval_every=0, eval_episodes=1, checkpoint_every=0,
                       hyperparams=hyper)  # fmt: skip


def _last_rate(run_dir) -> float:
    model, _ = load_run(run_dir)
    return model.policy.optimizer.param_groups[0]["lr"]


def test_an_annealed_run_decays_to_zero_and_resumes_exactly(tmp_path):
    quiet = dict(log=lambda *a: None)
    ref = train(_cfg(True), tmp_path / "ref", **quiet)
    assert ref["hyperparameters"]["anneal_lr"] is True
    assert _last_rate(tmp_path / "ref") == 0.0  # the last update ran at the end of the budget
    train(_cfg(None), tmp_path / "plain", **quiet)
    assert _last_rate(tmp_path / "plain") == pytest.approx(1e-3)
    # Cut halfway: the resumed run reads the same progress, so its weights are the same.
    assert train(_cfg(True), tmp_path / "cut", stop_at=128, **quiet) is None
    train(_cfg(True), tmp_path / "cut", **quiet)
    a, _ = load_run(tmp_path / "ref")
    b, _ = load_run(tmp_path / "cut")
    c, _ = load_run(tmp_path / "plain")
    sa, sb, sc = a.policy.state_dict(), b.policy.state_dict(), c.policy.state_dict()
    assert all(th.equal(sa[k], sb[k]) for k in sa)
    assert not all(th.equal(sa[k], sc[k]) for k in sa)  # the decay changed the updates


@pytest.mark.parametrize("value", [1, 0, "yes", 0.5])
def test_anything_but_a_bool_is_refused(value):
    with pytest.raises(ConfigError, match=f"anneal_lr={value!r}: must be True or False"):
        _cfg(value)
    with pytest.raises(ConfigError, match="anneal_lr=1: must be True or False"):
        TrainConfig("E1S1", algo="ppo", hyperparams={"anneal_lr": 1})
