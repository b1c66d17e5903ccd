"""Table I complete: the ``standard`` profile and the report's new columns (95 % interval,
normalised score, Table I best, targets, pending cells) on a tiny fake run directory."""

from __future__ import annotations

import json
import math

import pytest
from test_benchmark import fake_result

from multicrane.benchmark import aggregate, page, scores
from multicrane.benchmark.estimate import estimate_seconds, estimate_wall
from multicrane.benchmark.profiles import PROFILES, make_sweep
from multicrane.benchmark.reference import TABLE_I
from multicrane.benchmark.report import write_report
from multicrane.envs.paper_env import PAPER_CONFIGS
from multicrane.training.config import TrainConfig


def test_standard_profile_covers_table_one_within_budget():
    p = PROFILES["standard"]
    assert p.configs == PAPER_CONFIGS  # all 16 configurations
    assert "maskable_ppo" in p.algos and "double_dqn" in p.hyperparams  # --algos adds it
    assert len(p.seeds) == 5 and p.steps <= 200_000
    sweep = make_sweep("standard")
    runs = sweep.runs()
    assert len(runs) == 16 * len(p.algos) * 5
    for spec in runs[:: len(p.seeds)]:  # every setting is a valid training configuration
        TrainConfig(**spec.train)
    # the CPU estimate of the whole sweep: under 2 hours on 2 workers
    assert estimate_wall(runs, workers=2) < 2 * 3600
    assert all(estimate_seconds(s) > 0 for s in runs)


def test_paper_best_and_normalised_by_hand():
    assert scores.paper_best("E1S3") == (-2.62, 0.30, "DQN/DDQN")  # a tie: both columns
    assert scores.paper_best("E3S4") == (-140.18, 7.48, "PPO")  # the sign restored
    assert scores.paper_best("E9S9") is None
    assert scores.normalised(-100.0, random=-200.0, optimal=0.0) == pytest.approx(0.5)
    assert scores.normalised(0.0, random=-200.0, optimal=0.0) == pytest.approx(1.0)
    assert scores.normalised(-5.0, random=-2.0, optimal=-2.0) is None  # no range to scale


def _fake_sweep(tmp_path):
    """E1S1 x {double_dqn, maskable_ppo} x 3 seeds done, E3S4 double DQN 1 of 3, E3S4
    MaskablePPO none (pending)."""
    sweep = make_sweep(
        "standard",
        configs=["E1S1", "E3S4"],
        algos=["double_dqn", "maskable_ppo"],
        seeds=[0, 1, 2],
        out=tmp_path / "s",
    )
    returns = {
        ("E1S1", "double_dqn"): [-2.0, -3.0, -4.0],
        ("E1S1", "maskable_ppo"): [-100.0, -2.0, -2.0],
        ("E3S4", "double_dqn"): [-50.0],
    }
    for spec in sweep.runs():
        values = returns.get((spec.config, spec.algo), [])
        if spec.seed >= len(values):
            continue
        run_dir = spec.dir(sweep.out)
        run_dir.mkdir(parents=True)
        optimal = -2.0 if spec.config == "E1S1" else 3.8
        result = fake_result(spec.train, ret=values[spec.seed], optimal=optimal)
        (run_dir / "result.json").write_text(json.dumps(result))
    results, problems = aggregate.collect(sweep)
    assert problems == []
    return sweep, results, aggregate.make_cells(sweep, results)


def _row(text: str, config: str, label: str) -> list[str]:
    for line in text.splitlines():
        cols = [c.strip() for c in line.strip("|").split("|")]
        if cols[:2] == [config, label]:
            return cols
    raise AssertionError(f"no row {config} {label}")


def test_report_columns_on_a_fake_sweep(tmp_path):
    sweep, _, cells = _fake_sweep(tmp_path)
    base = {"E1S1": scores.Baseline(-182.0, -2.0), "E3S4": scores.Baseline(-578.2, 3.8)}
    text = page.markdown(sweep, cells, {}, baseline=base)
    assert "(1 of 4 cells pending)" in text
    row = _row(text, "E1S1", "double DQN")
    assert row[2] == "3/3" and row[3] == "-3.00 ± 0.58"
    # 95 % interval: mean +- t(0.975, 2) * s.e. = -3 +- 4.303 / sqrt(3)
    half = 4.303 / math.sqrt(3)
    assert row[4] == f"[{-3 - half:.2f}, {-3 + half:.2f}]"
    assert row[5] == "100%" and row[6] == "-2.00" and row[7] == "50.0 %"
    # normalised score per seed (r + 182) / 180, then mean +- s.e.
    per_seed = [(r + 182.0) / 180.0 for r in (-2.0, -3.0, -4.0)]
    assert row[8].startswith(f"{sum(per_seed) / 3:.3f} ± ")
    # MaskablePPO: (-100 + 182) / 180 = 0.456, then 1, 1: mean 0.819
    best = TABLE_I["E1S1"][1]  # DDQN's -4.27 is E1S1's best entry
    assert row[9] == f"{best[0]:.2f} ± {best[1]:.2f} (DDQN)"
    assert row[10] == "met"
    # a seed stuck at -100 pulls the score under 0.95 and the mean under Table I's best
    row = _row(text, "E1S1", "MaskablePPO")
    assert "not above Table I's best (-4.27)" in row[10]
    assert "normalised score 0.819 < 0.95" in row[10]
    # one seed of three: no s.e., no interval, verdict provisional
    row = _row(text, "E3S4", "double DQN")
    assert row[2] == "1/3" and row[3] == "-50.00 ± n/a" and row[4] == "n/a"
    assert row[9] == "-140.18 ± 7.48\\* (PPO)" and row[10] == "met (so far)"
    row = _row(text, "E3S4", "MaskablePPO")
    assert row[2] == "0/3" and row[3:6] == ["pending"] * 3 and row[10] == "pending"
    assert row[6] == "3.80" and row[7:9] == ["pending"] * 2  # the optimum, known already
    # which entries are whose, and where they were measured
    assert scores.OURS in text and scores.PAPERS in text
    assert "E1S1 -182.00" in text  # the random returns used
    assert "Cells that miss a target (1): E1S1 MaskablePPO: not above" in text


def test_summary_json_has_the_new_columns(tmp_path):
    sweep, _, _ = _fake_sweep(tmp_path)
    base = {"E1S1": scores.Baseline(-182.0, -2.0), "E3S4": scores.Baseline(-578.2, 3.8)}
    write_report(sweep, {}, plots=False, log=lambda _: None, baseline=base)
    data = json.loads((sweep.out / "summary.json").read_text())
    by = {(c["config"], c["algo"]): c for c in data["cells"]}
    e1 = by[("E1S1", "double_dqn")]
    assert e1["random_mean"] == -182.0 and e1["paper_best"] == -4.27 and e1["misses"] == []
    assert e1["normalised_mean"] == pytest.approx((180 + 179 + 178) / 3 / 180)
    assert by[("E3S4", "maskable_ppo")]["misses"] is None  # pending: no verdict
    assert "pending" in (sweep.out / "report.md").read_text()
    write_report(sweep, {}, plots=False, log=lambda _: None)  # no random: no new columns
    data = json.loads((sweep.out / "summary.json").read_text())
    assert "normalised_mean" not in data["cells"][0]


def test_baselines_on_the_evaluation_episodes():
    calls = []

    def make_policy(env, seed):
        calls.append(seed)
        return lambda obs: 4  # always up: blocked moves cost -1 each, 100 steps

    out = scores.baselines(["E2S2"], 2, make_policy)
    assert calls == [1_000_000, 1_000_001]
    # E2S2 has fixed starts: its optimum is -4.83 in every episode (docs/paper-results.md)
    assert out == {"E2S2": scores.Baseline(pytest.approx(-100.0), pytest.approx(-4.83, abs=0.01))}
