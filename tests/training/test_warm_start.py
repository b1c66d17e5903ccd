"""Warm starts (``TrainConfig.init_from``, ``multicrane.training.warm_start``): a fresh run
begins from a finished run's weights; with a teacher it runs only the rounds (expert
iteration after PPO); a run that does not fit is refused by name."""

from __future__ import annotations

import argparse
import json

import pytest
import torch as th
from conftest import one_torch_thread  # noqa: F401 (fixture)

import policies
from multicrane.training import ConfigError, TrainConfig, train
from multicrane.training.dagger import rounds_file
from multicrane.training.model_policy import load_run
from multicrane.training.warm_start import weights_digest

pytestmark = pytest.mark.usefixtures("one_torch_thread")
QUIET = {"log": lambda *a: None}


def _cfg(seed: int = 0, rate: float = 1e-3, **options) -> TrainConfig:
    return TrainConfig("e3s3", paper=False, n_cranes=2, decisions="task", algo="maskable_ppo",
                       policy="set", reward="makespan", shaping=0.0, n_envs=2,
                       total_steps=32, eval_episodes=2, checkpoint_every=0, seed=seed,
                       hyperparams={"n_steps": 16, "batch_size": 32, "n_epochs": 1,
                                    "learning_rate": rate}, **options)  # fmt: skip


def _weights(run_dir) -> dict:
    model, _ = load_run(run_dir)
    return model.policy.state_dict()


def _same(a: dict, b: dict) -> bool:
    return all(th.equal(a[k], b[k]) for k in a)


@pytest.fixture(scope="module")
def source(tmp_path_factory):
    """A finished set-policy run (seed 7) to start from."""
    run_dir = tmp_path_factory.mktemp("runs") / "source"
    train(_cfg(seed=7), run_dir, **QUIET)
    return run_dir


def test_a_warm_start_begins_from_the_runs_weights(source, tmp_path):
    """At learning rate 0 the warm run ends with the source's weights; a cold run of the same
    seed does not, and result.json names the source and its weights' digest."""
    warm = train(_cfg(rate=0.0, init_from=str(source)), tmp_path / "warm", **QUIET)
    cold = train(_cfg(rate=0.0), tmp_path / "cold", **QUIET)
    mine = _weights(source)
    assert _same(_weights(tmp_path / "warm"), mine)
    assert not _same(_weights(tmp_path / "cold"), mine)
    model, _ = load_run(source)
    assert warm["init_from"] == {"run": str(source), "weights": weights_digest(model.policy)}
    assert "init_from" not in cold
    saved = json.loads((tmp_path / "warm" / "config.json").read_text())
    assert saved["init_from"] == str(source)


def test_expert_iteration_after_a_finished_run_skips_the_first_imitation(source, tmp_path):
    from policies.lookahead import LookaheadTeacher

    demos = tmp_path / "demos.npz"
    cfg = _cfg(rate=0.0, init_from=str(source), imitate="lookahead", expert_iteration=1,
               round_episodes=2, imitate_epochs=2, imitate_demos=str(demos))  # fmt: skip
    teacher = LookaheadTeacher(candidates=1)
    result = train(cfg, tmp_path / "expit", teacher=teacher, **QUIET)
    rounds = result["imitation"]["rounds"]["rounds"]
    assert [r["round"] for r in rounds] == ["init", "expit-1"]
    assert rounds[1]["played"] == "teacher" and rounds[1]["rows"] > 0
    assert not demos.exists()  # no teacher episodes for a first imitation
    assert rounds_file(str(demos), "expit", cfg.seed, 1).exists()
    assert result["imitation"]["init_from"] == str(source)
    again = train(cfg, tmp_path / "again", teacher=teacher, **QUIET)  # reads the round's rows
    timeless = lambda rs: [{k: v for k, v in r.items() if k != "seconds"} for r in rs]  # noqa: E731
    assert timeless(again["imitation"]["rounds"]["rounds"]) == timeless(rounds)
    assert _same(_weights(tmp_path / "again"), _weights(tmp_path / "expit"))


def test_a_run_that_does_not_fit_is_refused_by_name(source, tmp_path):
    hinted = _cfg(init_from=str(source), planner_hint=True)  # one more weight, the hint's
    with pytest.raises(ConfigError, match="init_from=.*does not fit this run's"):
        train(hinted, tmp_path / "hinted", **QUIET)
    graph = _cfg(init_from=str(source), graph_features=True)  # a wider task row
    with pytest.raises(ConfigError, match="does not fit.*planner hint, graph features"):
        train(graph, tmp_path / "graph", **QUIET)
    with pytest.raises(ConfigError, match="init_from=.*no such run directory"):
        train(_cfg(init_from=str(tmp_path / "nowhere")), tmp_path / "none", **QUIET)
    (tmp_path / "empty").mkdir()
    with pytest.raises(ConfigError, match="init_from=.*empty"):
        train(_cfg(init_from=str(tmp_path / "empty")), tmp_path / "e", **QUIET)
    mlp = TrainConfig("e3s3", paper=False, n_cranes=2, decisions="task", algo="maskable_ppo",
                      total_steps=32, init_from=str(source))  # fmt: skip
    with pytest.raises(ConfigError, match=r"trained as \(algo, paper, policy\)"):
        train(mlp, tmp_path / "mlp", **QUIET)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"init_from": ""}, "init_from='': must be a run directory's path"),
        ({"init_from": "runs/x", "imitate": "prioritized"}, "give dagger or expert_iteration"),
    ],
)
def test_bad_warm_start_settings_are_refused(options, message):
    with pytest.raises(ConfigError, match=message):
        _cfg(**options)


def test_the_train_command_passes_init_from():
    from multicrane.cli import train as train_cli

    parser = argparse.ArgumentParser()
    train_cli.register(parser.add_subparsers())
    argv = ["train", "--scenario", "hall-4c", "--cranes", "4", "--decisions", "task",
            "--policy", "set", "--init-from", "runs/a", "--imitate", "lookahead",
            "--expert-iteration", "2"]  # fmt: skip
    cfg = train_cli.build_config(parser.parse_args(argv))
    assert (cfg.init_from, cfg.expert_iteration) == ("runs/a", 2)
    assert policies.split_spec(cfg.imitate)[0] == "lookahead"
