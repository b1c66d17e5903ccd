"""The ``paper-budget`` profile: the lean PPO on every configuration and the paper's four SB3
algorithms on Env1/Env2, 1,000,000 steps per run, and the time it is estimated to take."""

from __future__ import annotations

from collections import Counter
from dataclasses import replace

from multicrane.benchmark import aggregate, page
from multicrane.benchmark.estimate import estimate_seconds, estimate_wall, longest_first
from multicrane.benchmark.profiles import PAPER_ALGOS, PROFILES, make_sweep
from multicrane.envs.paper_env import PAPER_CONFIGS
from multicrane.training.config import TrainConfig

ENV1_ENV2 = tuple(c for c in PAPER_CONFIGS if c[:2] in ("E1", "E2"))


def test_paper_budget_runs_lean_ppo_everywhere_and_sb3_on_env1_env2():
    p = PROFILES["paper-budget"]
    assert p.algos == ("lean_ppo", "dqn", "double_dqn", "a2c", "ppo")
    sweep = make_sweep("paper-budget")
    runs = sweep.runs()
    assert len(runs) == 16 * 5 + 4 * 8 * 5
    assert Counter(r.algo for r in runs) == {"lean_ppo": 80, **dict.fromkeys(PAPER_ALGOS, 40)}
    assert {r.config for r in runs if r.algo == "lean_ppo"} == set(PAPER_CONFIGS)
    for algo in PAPER_ALGOS:
        assert {r.config for r in runs if r.algo == algo} == set(ENV1_ENV2)
    assert {r.seed for r in runs} == set(range(5))
    for spec in runs:
        t = spec.train
        assert t["total_steps"] == 1_000_000 and t["paper"] is True and t["final_episodes"] == 20
        if spec.algo == "lean_ppo":  # ours: 64 copies, minibatch 256, 128-128, shaped reward
            net = [256, 256] if spec.config == "E4S3" else [128, 128]  # E4S3's greedy loops
            assert t["hyperparams"] == {"batch_size": 256, "policy_kwargs": {"net_arch": net}}
            assert t["n_envs"] == 64
            assert (t["shaping"], t["potential"], t["shaping_gamma"]) == (1.0, "path", 1.0)
        else:  # the paper's settings and reward
            assert t["hyperparams"] == {} and t["n_envs"] is None and t["shaping"] is None
            assert "potential" not in t and "shaping_gamma" not in t
    for spec in runs[:: len(p.seeds)]:  # every setting is a valid training configuration
        TrainConfig(**spec.train)
    assert sweep.to_dict()["algo_configs"] == {a: list(ENV1_ENV2) for a in PAPER_ALGOS}
    wide = {"lean_ppo": {"E4S3": {"policy_kwargs": {"net_arch": [256, 256]}}}}
    assert sweep.to_dict()["config_hyperparams"] == wide
    # picking runs keeps a configuration's own settings; other algorithms have none
    (picked,) = make_sweep("paper-budget", configs=["E4S3"], algos=["lean_ppo"], seeds=[1]).runs()
    assert picked.train["hyperparams"]["policy_kwargs"] == {"net_arch": [256, 256]}
    assert make_sweep("paper-budget", algos=["dqn"]).to_dict()["config_hyperparams"] == {}


def test_paper_budget_estimate_lean_ppo_under_two_hours_sb3_the_long_pole():
    runs = make_sweep("paper-budget").runs()
    lean = [r for r in runs if r.algo == "lean_ppo"]
    # issue 32's target for its 80 runs: 2 hours (the 256-256 network everywhere: ~2.8 h)
    assert 1.8 * 3600 < estimate_wall(lean, workers=2) < 2 * 3600
    # a lean PPO run: 1,000,000 steps at ~6,500 steps/s (128-128), plus 64 evaluation episodes
    assert 155 < estimate_seconds(lean[0]) < 160 < estimate_seconds(lean[-1]) < 180
    wide = [r for r in lean if r.config == "E4S3"]  # 256-256: ~4,100 steps/s
    assert len(wide) == 5 and all(260 < estimate_seconds(r) < 270 for r in wide)
    assert {r.config for r in longest_first(lean)[:5]} == {"E4S3"}
    everywhere = {"batch_size": 256, "policy_kwargs": {"net_arch": [256, 256]}}
    everywhere = [replace(r, train={**r.train, "hyperparams": everywhere}) for r in lean]
    assert 2.7 * 3600 < estimate_wall(everywhere, workers=2) < 2.9 * 3600
    narrow = {"batch_size": 256}  # the 64-64 network: ~10,000 steps/s
    narrow = replace(lean[0], train={**lean[0].train, "hyperparams": narrow})
    assert 100 < estimate_seconds(narrow) < 110
    default = replace(lean[0], train={**lean[0].train, "hyperparams": {}, "n_envs": None})
    assert 50 < estimate_seconds(default) < 60  # the defaults: ~20,000 steps/s
    wide = {"policy_kwargs": {"net_arch": [256, 256]}}
    wide = replace(lean[0], train={**lean[0].train, "hyperparams": wide, "n_envs": None})
    assert 130 < estimate_seconds(wide) < 140  # a 256-256 network: ~7,500 steps/s
    # DQN's one gradient step per env step: ~37 min a run, the whole sweep over a day
    assert longest_first(runs)[0].algo in ("dqn", "double_dqn")
    assert 2000 < estimate_seconds(next(r for r in runs if r.algo == "dqn")) < 2500
    assert 24 * 3600 < estimate_wall(runs, workers=2) < 32 * 3600


def test_picking_runs_keeps_each_algorithms_configurations(tmp_path):
    assert make_sweep("paper-budget", configs=["E3"], algos=["dqn"]).runs() == []
    picked = make_sweep("paper-budget", configs=["E1S1", "E4S4"], seeds=[0], out=tmp_path)
    assert [r.name for r in picked.runs()] == [
        "E1S1/lean_ppo/seed0", "E1S1/dqn/seed0", "E1S1/double_dqn/seed0", "E1S1/a2c/seed0",
        "E1S1/ppo/seed0", "E4S4/lean_ppo/seed0",
    ]  # fmt: skip
    # the report: a pair the sweep does not run has no seeds, so it is not "missing"
    cells = aggregate.make_cells(picked, {})
    assert [(c.config, c.algo) for c in cells if c.missing] == [
        (r.config, r.algo) for r in picked.runs()
    ]
    assert "- Runs: 0 of 6 finished." in page.run_lines(picked, cells, {}, [])
