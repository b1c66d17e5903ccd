"""A task-level run directory on the command line: plan and replay play it at its own level."""

from __future__ import annotations

import types

import pytest

from multicrane.cli import main
from multicrane.cli.common import run_decisions


def _factory(decisions):
    config = None if decisions is None else types.SimpleNamespace(decisions=decisions)
    return types.SimpleNamespace(config=config)


@pytest.mark.parametrize(
    "given, trained, expected",
    [
        (None, [], "motion"),  # planners only
        (None, [None, "task"], "task"),  # a planner beside a task-level run
        (None, ["motion"], "motion"),
        ("motion", ["task"], "motion"),  # the option wins (the policy then refuses clearly)
        ("task", [None], "task"),
    ],
)
def test_the_decision_level_is_the_options_or_the_runs(given, trained, expected):
    assert run_decisions(given, [_factory(d) for d in trained]) == expected


def test_runs_of_different_levels_need_the_option():
    with pytest.raises(ValueError, match="different decision levels.*give --decisions"):
        run_decisions(None, [_factory("task"), _factory("motion")])


@pytest.fixture(scope="module")
def set_run(tmp_path_factory):
    pytest.importorskip("sb3_contrib")
    import torch as th

    th.set_num_threads(1)
    out = tmp_path_factory.mktemp("runs") / "e2s2-set"
    argv = ["train", "--scenario", "e2s2", "--cranes", "2", "--decisions", "task", "--policy",
            "set", "--steps", "64", "--envs", "2", "--eval-episodes", "1", "--checkpoint-every",
            "0", "--set", "n_steps=16", "--set", "batch_size=32", "--no-progress", "--out",
            str(out)]  # fmt: skip
    assert main(argv) == 0
    return out


def test_plan_plays_a_set_policy_run_at_task_level_and_records_it(set_run, tmp_path, capsys):
    record = tmp_path / "ep.json.gz"
    argv = ["plan", "e2s2", "--cranes", "2", "--policy", str(set_run), "--seed", "3",
            "--record", str(record)]  # fmt: skip
    assert main(argv) == 0
    assert "100%" in capsys.readouterr().out  # e2s2 with 2 cranes: a task policy finishes
    pytest.importorskip("rerun")
    # The record re-simulates step by step (task decisions are recorded as physical moves).
    assert main(["replay", "replay", str(record), "--rrd", str(tmp_path / "r.rrd")]) == 0


def test_plan_at_motion_level_refuses_a_set_policy_clearly(set_run, capsys):
    argv = ["plan", "e2s2", "--cranes", "2", "--policy", str(set_run), "--decisions", "motion"]
    assert main(argv) != 0
    assert "is a set policy: it needs decisions=task" in capsys.readouterr().err


def test_replay_record_plays_a_set_policy_run_at_task_level(set_run, tmp_path, capsys):
    from multicrane.replay.record import EpisodeRecord

    path = tmp_path / "ep.json.gz"
    argv = ["replay", "record", "--scenario", "e2s2", "--cranes", "2", "--policy",
            str(set_run), "--seed", "5", "--record", str(path)]  # fmt: skip
    assert main(argv) == 0
    assert "success" in capsys.readouterr().out
    assert EpisodeRecord.load(path).seed == 5
