"""Evaluating policies: ``multicrane.episodes.rollout`` on hand-made episodes, policies by name
(``policies.registry``), ``multicrane evaluate`` and the main job ``multicrane demo``."""

from __future__ import annotations

import json
import math

import pytest

import multicrane
from multicrane.episodes.rollout import evaluate as evaluate_policy
from multicrane.episodes.rollout import optimal_returns, summarise
from policies import PolicyError, factory

pytest.importorskip("stable_baselines3")

from multicrane.cli import main  # noqa: E402
from multicrane.training import TrainConfig, train  # noqa: E402


def test_summary_of_hand_made_episodes():
    episodes = [
        {"return": -2.0, "success": True, "steps": 20},
        {"return": -4.0, "success": True, "steps": 30},
        {"return": -9.0, "success": False, "steps": 100},
    ]
    s = summarise(episodes, optimal=[-1.0, -2.0, -3.0])
    assert s["return_mean"] == pytest.approx(-5.0)
    assert s["return_sem"] == pytest.approx(math.sqrt(13.0) / math.sqrt(3.0))
    assert s["success_rate"] == pytest.approx(2 / 3)
    assert s["steps_mean"] == pytest.approx(50.0)
    assert s["finish_steps_mean"] == pytest.approx(25.0)
    assert s["optimal_mean"] == pytest.approx(-2.0)
    assert s["gap"] == pytest.approx(3.0)
    assert s["gap_pct"] == pytest.approx(150.0)
    one = summarise(episodes[2:])
    assert one["return_sem"] is None and one["finish_steps_mean"] is None  # s.e. of one: None
    with pytest.raises(ValueError):
        summarise([])


@pytest.mark.parametrize("config", ["E1S1", "E2S3", "E3S2"])
def test_optimal_has_no_gap_and_random_a_large_one(config):
    env = multicrane.PaperAssemblyEnv(config)
    seeds = [0, 1, 2]
    best_returns = optimal_returns(env, seeds)
    _, best = evaluate_policy(env, factory("optimal", paper=True), seeds, optimal=best_returns)
    assert best["gap"] == pytest.approx(0.0, abs=1e-9)
    assert best["success_rate"] == 1.0
    _, rnd = evaluate_policy(env, factory("random", paper=True), seeds, optimal=best_returns)
    assert rnd["gap"] > 50 and rnd["success_rate"] == 0.0


def test_policy_names_are_checked():
    with pytest.raises(PolicyError, match="prioritized"):
        factory("prioritized", paper=True)  # a multi-agent planner
    with pytest.raises(PolicyError, match="optimal"):
        factory("optimal", paper=False)
    with pytest.raises(PolicyError, match="no such run directory"):
        factory("no/such/run", paper=False)


def test_evaluate_program_takes_policies_with_options_and_prints_their_whole_labels(
    tmp_path, capsys
):
    long = "prioritized:rank=nearest,max_searches=2"  # more than the 44 columns of a name
    out = tmp_path / "ev.json"
    assert main(["evaluate", "--scenario", "e3s2", "--cranes", "2", "--decisions", "task",
                 "--episodes", "2", "--policy", "lookahead:candidates=1", long, "prioritized",
                 "--json", str(out)]) == 0  # fmt: skip
    printed = capsys.readouterr().out
    assert "lookahead:candidates=1 " in printed and f"{long} " in printed
    rows = json.loads(out.read_text())
    assert [r["policy"] for r in rows] == ["lookahead:candidates=1", long, "prioritized"]
    assert main(["evaluate", "--scenario", "e3s2", "--decisions", "task", "--episodes", "1",
                 "--policy", "lookahead:candidates"]) != 0  # fmt: skip
    assert "option 'candidates' is not KEY=VALUE" in capsys.readouterr().err


@pytest.fixture(scope="module")
def paper_run(tmp_path_factory):
    run_dir = tmp_path_factory.mktemp("runs") / "e1s1-ppo"
    cfg = TrainConfig(
        "E1S1", paper=True, algo="ppo", total_steps=256, n_envs=2, eval_episodes=2,
        hyperparams={"n_steps": 64, "batch_size": 64},
    )  # fmt: skip
    train(cfg, run_dir, log=lambda *_: None)
    return run_dir


def test_evaluate_program_compares_a_trained_model_with_planners(paper_run, tmp_path, capsys):
    out = tmp_path / "eval.json"
    code = main(
        ["evaluate", "--paper", "E1S1", "--policy", str(paper_run), "optimal", "greedy",
         "--episodes", "3", "--json", str(out)]
    )  # fmt: skip
    assert code == 0
    text = capsys.readouterr().out
    assert "ppo (e1s1-ppo)" in text and "optimal" in text and "gap" in text
    rows = json.loads(out.read_text())
    assert [r["policy"] for r in rows] == ["ppo (e1s1-ppo)", "optimal", "greedy"]
    seeds = [[e["seed"] for e in r["episodes"]] for r in rows]
    assert seeds[0] == seeds[1] == seeds[2] == [1_000_000, 1_000_001, 1_000_002]
    by = {r["policy"]: r["summary"] for r in rows}
    assert by["optimal"]["gap"] == pytest.approx(0.0, abs=1e-9)
    assert by["ppo (e1s1-ppo)"]["return_mean"] <= by["optimal"]["return_mean"] + 1e-9


def test_evaluate_program_sets_the_torch_threads_of_trained_models(paper_run, capsys):
    """--threads N (default 1) sets torch's threads once a trained model is loaded: a small
    network is slower on more, and a search's timings beside other processes are honest."""
    import torch

    before = torch.get_num_threads()
    try:
        for threads in (2, 1):
            assert main(["evaluate", "--paper", "E1S1", "--policy", str(paper_run),
                         "--episodes", "1", "--threads", str(threads)]) == 0  # fmt: skip
            assert torch.get_num_threads() == threads
    finally:
        torch.set_num_threads(before)
    assert main(["evaluate", "--paper", "E1S1", "--policy", "greedy", "--threads", "0"]) == 2
    assert "--threads 0: must be at least 1" in capsys.readouterr().err


def test_evaluate_program_refuses_a_model_of_the_other_mode(paper_run, capsys):
    code = main(["evaluate", "--scenario", "e1s1", "--cranes", "2", "--policy", str(paper_run)])
    assert code == 2
    assert "single-agent benchmark mode" in capsys.readouterr().err


_TIMING = ("plan_seconds", "plan_ms_per_step", "plan_ms_per_crane", "plan_ms_max")


def test_set_evaluation_in_workers_plays_the_same_episodes(tmp_path, capsys):
    """--workers N spreads a set's (policy, site) pairs over processes; the rows (order,
    episodes, summaries) are those of one process, timings aside."""
    rows = {}
    for workers in (1, 2):
        out = tmp_path / f"w{workers}.json"
        code = main(["evaluate", "--scenario", "set:train:0-3", "--decisions", "task",
                     "--episodes", "2", "--policy", "prioritized", "random",
                     "--workers", str(workers), "--json", str(out)])  # fmt: skip
        assert code == 0, capsys.readouterr().err
        rows[workers] = json.loads(out.read_text())
    assert [r["policy"] for r in rows[2]] == ["prioritized", "random"]
    for one, two in zip(rows[1], rows[2], strict=True):
        assert len(one["episodes"]) == 3 * 2 and one["summary"]["sites"] == 3
        strip = [[{k: v for k, v in e.items() if k not in _TIMING} for e in r["episodes"]]
                 for r in (one, two)]  # fmt: skip
        assert strip[0] == strip[1]
        assert one["summary"]["makespan_mean"] == two["summary"]["makespan_mean"]
    assert main(["evaluate", "--scenario", "set:train:0-3", "--policy", "random",
                 "--workers", "0"]) == 2  # fmt: skip
    assert "--workers must be at least 1" in capsys.readouterr().err
    assert main(["evaluate", "--scenario", "e2s2", "--policy", "random", "--workers", "2"]) == 2
    assert "give --scenario set:NAME" in capsys.readouterr().err


@pytest.mark.long
@pytest.mark.parametrize("decisions, kind", [("task", "set"), ("motion", "maskable_ppo")])
def test_demo_trains_evaluates_and_records(tmp_path, capsys, decisions, kind):
    pytest.importorskip("rerun")
    argv = ["demo", "--scenario", "e1s1", "--cranes", "2", "--decisions", decisions, "--steps",
            "512", "--episodes", "2", "--bound-time", "2",
            "--out", str(tmp_path)]  # fmt: skip
    assert main(argv) == 0
    out = capsys.readouterr().out
    run_dir = tmp_path / f"e1s1-2c-{kind}-s0"
    for name in ("model.zip", "result.json", "evaluation.json", "evaluation.md", "replay.rrd",
                 "episode.json.gz"):  # fmt: skip
        assert (run_dir / name).is_file(), name
    policies = [r["policy"] for r in json.loads((run_dir / "evaluation.json").read_text())]
    planners = ["prioritized", "lookahead"] if decisions == "task" else ["prioritized"]
    assert policies[1:] == [*planners, "greedy", "random"]
    if decisions == "task":  # from random weights, no demonstrations, no hint, time-limited
        result = json.loads((run_dir / "result.json").read_text())
        assert "imitation" not in result and "init_from" not in result
        config = result["config"]
        assert not config["planner_hint"] and config["hyperparams"] == {"learning_rate": 1e-3}
        assert config["time_limit"] == 780.0 and config["keep_best"]
    assert "gap to bound" in (run_dir / "evaluation.md").read_text()
    assert "replay:" in out
    # Again: the finished training is reused, not repeated.
    mtime = (run_dir / "model.zip").stat().st_mtime_ns
    assert main(argv) == 0
    assert (run_dir / "model.zip").stat().st_mtime_ns == mtime


def test_evaluate_plot_has_the_runs_learning_curve_against_wall_time(paper_run, tmp_path, capsys):
    pytest.importorskip("matplotlib")
    from test_comparison_plot import assert_plausible_png

    from multicrane.reports.comparison_data import curve_panel, run_curves

    out, plot = tmp_path / "eval.json", tmp_path / "eval.png"
    code = main(["evaluate", "--paper", "E1S1", "--policy", str(paper_run), "optimal",
                 "--episodes", "2", "--json", str(out), "--plot", str(plot)])  # fmt: skip
    assert code == 0 and f"plot: {plot}" in capsys.readouterr().out
    assert_plausible_png(plot)
    rows = json.loads(out.read_text())
    assert rows[0]["run"] == str(paper_run) and "run" not in rows[1]
    best = [e["return"] for e in rows[1]["episodes"]]
    assert [e["optimal_return"] for e in rows[0]["episodes"]] == pytest.approx(best)
    panel = curve_panel(run_curves({rows[0]["policy"]: [rows[0]["run"]]}), paper=True)
    curve = json.loads((paper_run / "result.json").read_text())["curve"]
    assert panel.xlabel == "training wall time (s)"
    assert panel.groups[0].runs == [[(p["seconds"], p["return_mean"]) for p in curve]]
