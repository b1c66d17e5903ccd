"""``TrainConfig.time_limit`` (``multicrane train --time-limit``): a run stops at the first
update boundary past its wall-time limit and finishes like a run that spent its budget; and
the time to a makespan that ``tools/marl_curve.py --reach`` reads from a run's curve."""

from __future__ import annotations

import json

import pytest
from conftest import load_tool, one_torch_thread  # noqa: F401 (fixture)

from multicrane.training import ConfigError, TrainConfig, train

pytestmark = pytest.mark.usefixtures("one_torch_thread")


@pytest.mark.parametrize("value", [0, -5.0, "60", True])
def test_a_bad_time_limit_is_refused_by_name(value):
    with pytest.raises(ConfigError, match="time_limit="):
        TrainConfig("E2S2", algo="ppo", time_limit=value)


def _config(total_steps: int = 100_000, **options) -> TrainConfig:
    return TrainConfig("e2s2", paper=False, n_cranes=2, decisions="task", algo="maskable_ppo",
                       policy="set", n_envs=2, total_steps=total_steps, eval_every=64,
                       eval_episodes=1, checkpoint_every=0, reward="makespan",
                       hyperparams={"n_steps": 16, "batch_size": 32, "n_epochs": 1},
                       **options)  # fmt: skip


def test_the_run_stops_past_its_limit_and_finishes(tmp_path, monkeypatch):
    from multicrane.training import trainer

    boundaries = []
    real = trainer._RunMonitor._on_rollout_start

    def recorded(self):
        boundaries.append(self.model.num_timesteps)
        real(self)

    # A clock that runs one second per ten steps trained: the limit falls between boundaries.
    monkeypatch.setattr(trainer.Run, "elapsed", lambda self: self.model.num_timesteps / 10)
    monkeypatch.setattr(trainer._RunMonitor, "_on_rollout_start", recorded)
    result = train(_config(time_limit=15.0), tmp_path / "run", log=lambda *a: None)
    first_past = next(step for step in boundaries if step >= 150)
    assert boundaries[-1] == first_past and boundaries[-2] < 150  # no update after it
    assert result["time_up"] == first_past
    assert first_past <= result["steps"] < first_past + 16 * 2  # not one more rollout
    assert result["steps"] < 100_000
    stored = json.loads((tmp_path / "run" / "result.json").read_text())
    assert stored["time_up"] == first_past and stored["config"]["time_limit"] == 15.0
    assert (tmp_path / "run" / "model.zip").exists()
    assert result["curve"][-1]["step"] == result["steps"]  # the final point is evaluated


def test_without_a_limit_nothing_is_recorded(tmp_path):
    result = train(_config(total_steps=64), tmp_path / "run", log=lambda *a: None)
    assert "time_up" not in result and result["steps"] >= 64


def test_the_command_line_option_reaches_the_config():
    import argparse

    from multicrane.cli import train as command

    parser = argparse.ArgumentParser()
    command.register(parser.add_subparsers())
    args = parser.parse_args(["train", "--scenario", "e2s2", "--cranes", "2", "--decisions",
                              "task", "--time-limit", "90"])  # fmt: skip
    assert command.build_config(args).time_limit == 90.0


def test_time_to_a_makespan_is_the_first_point_that_finished_every_episode_at_it():
    reached = load_tool("marl_curve").reached
    run = [
        {"step": 0, "seconds": 5.0, "steps_mean": 160.0, "success_rate": 1.0},
        {"step": 40_960, "seconds": 35.0, "steps_mean": 120.0, "success_rate": 0.5},
        {"step": 81_920, "seconds": 66.4, "steps_mean": 136.6, "success_rate": 1.0},
        {"step": 122_880, "seconds": 94.0, "steps_mean": 130.0, "success_rate": 1.0},
    ]
    assert reached(run, 136.6) == "136.6 reached at 81,920 decisions, 66 s"
    assert reached(run, 125.0) == "125.0 not reached in 122,880 decisions"
    assert reached([{k: v for k, v in p.items() if k != "seconds"} for p in run], 131.0) == (
        "131.0 reached at 122,880 decisions"
    )
