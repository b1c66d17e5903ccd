"""The benchmark harness: Table I's metric, profiles, resume, the backends, the report.

Most tests use a fake runner that writes the files a finished ``train`` run leaves (fast,
and it counts calls); one sweep trains for real through the local process pool, and one
through Ray when ray is installed (``-m ray`` selects it; it is skipped without ray).
"""

from __future__ import annotations

import importlib.util
import json
import math
import os
import signal
import sys
import threading
import time
from pathlib import Path

import pytest

from multicrane.benchmark import aggregate, page
from multicrane.benchmark.choices import SweepError, parse_configs, parse_seeds
from multicrane.benchmark.jobs import Job, Outcome
from multicrane.benchmark.local import LocalBackend
from multicrane.benchmark.manifest import sweep_lock
from multicrane.benchmark.profiles import (
    PROFILES,
    make_sweep,
)
from multicrane.benchmark.reference import TABLE_I
from multicrane.benchmark.runstate import (
    CONFLICT,
    CORRUPT,
    DONE,
    FAILED,
    PARTIAL,
    PENDING,
    inspect_run,
    prepare_run,
    store_result,
    sweep_states,
)
from multicrane.benchmark.serial import SerialBackend
from multicrane.benchmark.sweep import run_sweep
from multicrane.stats import mean_sem


def _have(module: str) -> bool:
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):  # ValueError: blocked in sys.modules
        return False


HAVE_MATPLOTLIB = _have("matplotlib")
HAVE_TRAINING = _have("stable_baselines3")


# -- fakes -------------------------------------------------------------------------------------


def fake_result(train: dict, ret: float = -5.0, success: float = 1.0, optimal: float = -2.0):
    """A result dict shaped like ``train``'s, for a run of ``train`` (TrainConfig kwargs)."""
    config = {"n_cranes": None, "mask_blocked_moves": None, "auto": False, "max_steps": None}
    config.update(train)
    steps = train["total_steps"]
    return {
        "config": config,
        "algorithm": train["algo"],
        "steps": steps,
        "final": {
            "episodes": train["eval_episodes"],
            "return_mean": ret,
            "return_sem": 0.0,
            "success_rate": success,
            "optimal_mean": optimal,
            "gap": optimal - ret,
        },
        "curve": [
            {"step": 0, "return_mean": -100.0},
            {"step": steps // 2, "return_mean": (ret - 100.0) / 2},
            {"step": steps, "return_mean": ret},
        ],
        "train_return_mean": ret - 10.0,
        "train_seconds": 1.0,
        "eval_seconds": 0.5,
        "versions": {"torch": "x"},
        "python": "3.11",
    }


def fake_train(task: Job) -> Outcome:
    """Write what a finished run leaves: config.json, then result.json."""
    run_dir = Path(task.run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / "config.json").write_text(json.dumps(task.train))
    result = fake_result(task.train, ret=-float(task.train["seed"]) - 3.0)
    (run_dir / "result.json").write_text(json.dumps(result))
    return Outcome(task.name, "done", final=result["final"])


def crash_on_seed1(task: Job) -> Outcome:
    """A runner whose process dies hard on seed 1 (for the local pool, which spawns)."""
    if task.train["seed"] == 1:
        os._exit(3)
    return fake_train(task)


def wait_for_sigterm(task: Job) -> Outcome:
    """A runner that behaves like ``train`` on SIGTERM: stops with a checkpoint."""
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(True))
    start = time.monotonic()
    while not stop and time.monotonic() - start < 30:
        time.sleep(0.02)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    if not stop:
        return fake_train(task)
    run_dir = Path(task.run_dir)
    (run_dir / "checkpoint").mkdir(parents=True)
    (run_dir / "config.json").write_text(json.dumps(task.train))
    (run_dir / "checkpoint" / "steps.txt").write_text("64\n")
    return Outcome(task.name, "stopped", detail="stopped with a checkpoint")


class Counting:
    """A fake runner that counts calls per run and can stop (like Ctrl-C) after n runs."""

    def __init__(self, stop_after: int | None = None):
        self.calls: dict[str, int] = {}
        self.stop_after = stop_after

    def __call__(self, task: Job) -> Outcome:
        self.calls[task.name] = self.calls.get(task.name, 0) + 1
        if self.stop_after is not None and sum(self.calls.values()) > self.stop_after:
            run_dir = Path(task.run_dir)
            run_dir.mkdir(parents=True, exist_ok=True)
            (run_dir / "config.json").write_text(json.dumps(task.train))
            (run_dir / "checkpoint").mkdir(exist_ok=True)
            (run_dir / "checkpoint" / "steps.txt").write_text("500\n")
            return Outcome(task.name, "stopped", detail="stopped with a checkpoint")
        return fake_train(task)


def quiet(_message: str) -> None:
    pass


def small_sweep(tmp_path: Path, **kwargs):
    options = {"configs": ["E1S1", "E2S2"], "algos": ["a2c", "ppo"], "seeds": [0, 1]}
    options.update(kwargs)
    return make_sweep("smoke", out=tmp_path / "sweep", **options)


# -- the metric --------------------------------------------------------------------------------


def test_mean_sem_by_hand():
    assert mean_sem([]) == (None, None)
    assert mean_sem([-4.0]) == (-4.0, None)
    mean, sem = mean_sem([-4.0, -6.0, -5.0])
    assert mean == pytest.approx(-5.0)
    # sample std (n-1) of -4, -6, -5 is 1; over sqrt(3)
    assert sem == pytest.approx(1 / math.sqrt(3))
    mean, sem = mean_sem([1.0, 3.0])
    assert (mean, sem) == (pytest.approx(2.0), pytest.approx(math.sqrt(2) / math.sqrt(2)))


def test_cell_mean_sem_success_gap_by_hand():
    train = {"total_steps": 10, "eval_episodes": 4, "algo": "ppo"}
    results = {
        0: fake_result(train, ret=-4.0, success=1.0, optimal=-2.0),
        1: fake_result(train, ret=-6.0, success=0.5, optimal=-2.0),
        2: fake_result(train, ret=-5.0, success=0.75, optimal=-2.0),
    }
    cell = aggregate.make_cell("E1S1", "ppo", results)
    assert cell.n == 3 and cell.missing == ()
    assert cell.mean == pytest.approx(-5.0)
    assert cell.sem == pytest.approx(1 / math.sqrt(3))
    assert cell.success_rate == pytest.approx(0.75)
    assert cell.optimal_mean == pytest.approx(-2.0)
    assert cell.gap == pytest.approx(3.0)  # optimal - ours
    assert cell.gap_pct == pytest.approx(150.0)  # of |optimal|
    assert cell.train_return[0] == pytest.approx(-15.0)
    d = cell.to_dict()
    assert d["final_returns"] == {"0": -4.0, "1": -6.0, "2": -5.0}
    assert d["train_seconds"] == pytest.approx(4.5)


def test_single_seed_has_no_standard_error():
    train = {"total_steps": 10, "eval_episodes": 4, "algo": "dqn"}
    cell = aggregate.make_cell("E2S1", "dqn", {0: fake_result(train, ret=-7.5)})
    assert cell.mean == -7.5 and cell.sem is None
    assert page._ours(cell, best=False) == "-7.50 ± n/a"


def test_missing_runs_are_reported_not_averaged():
    train = {"total_steps": 10, "eval_episodes": 4, "algo": "a2c"}
    cell = aggregate.make_cell("E1S2", "a2c", {0: fake_result(train, ret=-3.0), 1: None})
    assert cell.n == 1 and cell.missing == (1,)
    assert cell.mean == -3.0
    assert page._ours(cell, best=False) == "-3.00 ± n/a (1/2 seeds)"
    empty = aggregate.make_cell("E1S2", "a2c", {0: None, 1: None})
    assert empty.mean is None and empty.gap is None and empty.success_rate is None
    assert page._ours(empty, best=False) == "pending"


def test_markdown_report_from_result_files(tmp_path):
    sweep = make_sweep(
        "quick", configs=["E1S1", "E3S4"], algos=["double_dqn", "ppo"], out=tmp_path / "s"
    )
    for spec in sweep.runs():
        if spec.config == "E3S4" and spec.algo == "ppo" and spec.seed == 2:
            continue  # missing
        run_dir = spec.dir(sweep.out)
        run_dir.mkdir(parents=True)
        ret = -10.0 - spec.seed if spec.algo == "ppo" else -4.0
        (run_dir / "result.json").write_text(json.dumps(fake_result(spec.train, ret=ret)))
    results, problems = aggregate.collect(sweep)
    assert problems == []
    cells = aggregate.make_cells(sweep, results)
    text = page.markdown(sweep, cells, {"machine": "test box", "date": "today"})
    assert "30,000 environment steps per run, 3 seeds (0-2)" in text
    assert "- Runs: 11 of 12 finished." in text
    assert "E3S4/ppo seed 2" in text
    # ours beside the paper's columns: double DQN next to Table I "DQN" and "DDQN"
    header = next(line for line in text.splitlines() if line.startswith("| config | optimal"))
    assert header.index("double DQN") < header.index('Table I "DQN" (double DQN)')
    assert 'Table I "DDQN" (dueling double DQN)' in header
    row = next(line for line in text.splitlines() if line.startswith("| E1S1 |"))
    dqn, ddqn = TABLE_I["E1S1"][0], TABLE_I["E1S1"][1]
    assert f"{dqn[0]:.2f} ± {dqn[1]:.2f}" in row and f"{ddqn[0]:.2f} ± {ddqn[1]:.2f}" in row
    assert "**-4.00 ± 0.00**" in row  # the best of ours is bold
    row = next(line for line in text.splitlines() if line.startswith("| E3S4 |"))
    assert "-10.50 ± 0.50 (2/3 seeds)" in row  # seeds 0 and 1: -10, -11
    assert "-140.18 ± 7.48\\*" in row  # the sign fixed in Table I
    assert "Machine: test box" in text
    summary = aggregate.summary(sweep, cells)
    assert summary["cells"][0]["return_mean"] == pytest.approx(-4.0)
    assert json.loads(json.dumps(summary))  # JSON-ready


# -- profiles and runs -------------------------------------------------------------------------


def test_profiles_expand_to_the_expected_runs(tmp_path):
    assert len(make_sweep("smoke").runs()) == 2 * 5 * 1
    quick = make_sweep("quick")
    assert len(quick.runs()) == 8 * 5 * 3
    assert {r.config[:2] for r in quick.runs()} == {"E1", "E2"}
    assert quick.steps == PROFILES["quick"].steps
    paper = make_sweep("paper")
    assert len(paper.runs()) == 16 * 4 * 15
    assert paper.steps == 1_000_000 and paper.algos == ("dqn", "double_dqn", "a2c", "ppo")
    spec = paper.runs()[0]
    assert spec.name == "E1S1/dqn/seed0"
    assert spec.dir(tmp_path) == tmp_path / "E1S1" / "dqn" / "seed0"
    assert spec.train["total_steps"] == 1_000_000 and spec.train["scenario"] == "E1S1"
    assert spec.train["paper"] is True and spec.train["torch_threads"] == 1


def test_custom_choices_and_their_directories(tmp_path):
    picked = make_sweep("quick", configs=["e2"], algos=["ppo"], seeds=[4, 5])
    assert picked.configs == ("E2S1", "E2S2", "E2S3", "E2S4")
    assert picked.out == make_sweep("quick").out  # picking runs keeps the directories
    assert len(picked.runs()) == 4 * 1 * 2
    custom = make_sweep("quick", steps=5000)
    assert custom.out != make_sweep("quick").out  # another budget: another directory
    assert custom.name == "quick-5000steps-eval3000x10"
    assert make_sweep("quick", steps=5000, out=tmp_path).out == tmp_path
    assert parse_seeds(["0-2", "5,7"]) == (0, 1, 2, 5, 7)
    assert parse_configs(["E1S2", "e1s1", "all"])[:2] == ("E1S1", "E1S2")
    with pytest.raises(SweepError, match="unknown configuration 'E5S1'"):
        make_sweep("quick", configs=["E5S1"])
    with pytest.raises(SweepError, match="unknown algorithm 'sac'"):
        make_sweep("quick", algos=["sac"])
    with pytest.raises(SweepError, match="seed given twice: 1"):
        make_sweep("quick", seeds=[1, 1])
    with pytest.raises(SweepError, match="steps=0"):
        make_sweep("quick", steps=0)
    with pytest.raises(SweepError, match="unknown profile"):
        make_sweep("huge")


# -- run states and resume ---------------------------------------------------------------------


def test_inspect_and_prepare_each_state(tmp_path):
    sweep = small_sweep(tmp_path)
    spec = sweep.runs()[0]
    run_dir = spec.dir(sweep.out)
    assert inspect_run(spec, run_dir).kind == PENDING
    run_dir.mkdir(parents=True)
    (run_dir / "config.json").write_text(json.dumps(spec.train))
    assert inspect_run(spec, run_dir).kind == PARTIAL
    (run_dir / "checkpoint").mkdir()
    (run_dir / "checkpoint" / "steps.txt").write_text("640\n")
    state = inspect_run(spec, run_dir)
    assert (state.kind, state.steps) == (PARTIAL, 640)
    (run_dir / "error.txt").write_text("Traceback\nValueError: boom\n")
    assert inspect_run(spec, run_dir).detail == "ValueError: boom"
    assert inspect_run(spec, run_dir).kind == FAILED
    assert prepare_run(spec, run_dir, quiet).kind == PARTIAL  # error.txt cleared for a retry
    # a checkpoint stranded between the two renames of a save comes back
    (run_dir / "checkpoint").rename(run_dir / "checkpoint.tmp")
    assert inspect_run(spec, run_dir).steps == 640
    prepare_run(spec, run_dir, quiet)
    assert (run_dir / "checkpoint" / "steps.txt").exists()
    # a partial result file: corrupt, moved aside, then the run resumes
    (run_dir / "result.json").write_text('{"config": {"scenario": "E1')
    assert inspect_run(spec, run_dir).kind == CORRUPT
    assert prepare_run(spec, run_dir, quiet).kind == PARTIAL
    assert not (run_dir / "result.json").exists()
    assert len(list(run_dir.glob("result.json.corrupt-*"))) == 1
    # valid JSON without the final evaluation is partial too
    (run_dir / "result.json").write_text(json.dumps({"config": spec.train, "steps": 3}))
    assert inspect_run(spec, run_dir).kind == CORRUPT
    (run_dir / "result.json").write_text(json.dumps(fake_result(spec.train)))
    assert inspect_run(spec, run_dir).kind == DONE
    # another budget in the same directory
    other = make_sweep("smoke", configs=["E1S1"], algos=["a2c"], steps=777).runs()[0]
    state = inspect_run(other, run_dir)
    assert state.kind == CONFLICT and "total_steps: 1000 != 777" in state.detail


def test_unreadable_config_moves_the_directory_aside(tmp_path):
    sweep = small_sweep(tmp_path)
    spec = sweep.runs()[0]
    run_dir = spec.dir(sweep.out)
    run_dir.mkdir(parents=True)
    (run_dir / "config.json").write_text("{not json")
    assert inspect_run(spec, run_dir).kind == CORRUPT
    assert prepare_run(spec, run_dir, quiet).kind == PENDING
    assert len(list(run_dir.parent.glob("seed0.corrupt-*"))) == 1


def test_resume_skips_finished_runs_and_redoes_broken_ones(tmp_path):
    sweep = small_sweep(tmp_path)
    runner = Counting()
    first = run_sweep(sweep, SerialBackend(runner), log=quiet)
    assert first.complete and first.done_before == 0 and len(runner.calls) == 8
    assert set(runner.calls.values()) == {1}
    done = {s.name: s.dir(sweep.out) / "result.json" for s in sweep.runs()}
    stamps = {name: path.stat().st_mtime_ns for name, path in done.items()}

    second = run_sweep(sweep, SerialBackend(runner := Counting()), log=quiet)
    assert runner.calls == {} and second.done_before == 8 and second.complete
    assert {n: p.stat().st_mtime_ns for n, p in done.items()} == stamps

    broken, resumed = sweep.runs()[1], sweep.runs()[5]
    done[broken.name].write_text(done[broken.name].read_text()[:40])  # cut short
    done[resumed.name].unlink()  # a checkpoint, no result: resumed
    (done[resumed.name].parent / "checkpoint").mkdir()
    (done[resumed.name].parent / "checkpoint" / "steps.txt").write_text("100\n")
    assert sweep_states(sweep)[resumed].kind == PARTIAL
    third = run_sweep(sweep, SerialBackend(runner := Counting()), log=quiet)
    assert runner.calls == {broken.name: 1, resumed.name: 1}
    assert third.done_before == 6 and third.complete
    untouched = [n for n in done if n not in (broken.name, resumed.name)]
    assert all(done[n].stat().st_mtime_ns == stamps[n] for n in untouched)


def test_interrupted_sweep_completes_without_repeating_work(tmp_path):
    sweep = small_sweep(tmp_path)
    runner = Counting(stop_after=3)  # the fourth run is "interrupted" with a checkpoint
    first = run_sweep(sweep, SerialBackend(runner), log=quiet)
    assert first.interrupted and not first.complete
    assert first.count("done") == 3 and first.count("stopped") == 1
    finished = {o.name for o in first.outcomes if o.status == "done"}
    stopped = [o.name for o in first.outcomes if o.status == "stopped"]
    states = sweep_states(sweep)
    assert sum(s.kind == DONE for s in states.values()) == 3
    assert [spec.name for spec, s in states.items() if s.kind == PARTIAL] == stopped

    again = Counting()
    second = run_sweep(sweep, SerialBackend(again), log=quiet)
    assert second.complete and second.done_before == 3
    assert not finished & set(again.calls)  # nothing finished is run again
    assert set(again.calls) | finished == {s.name for s in sweep.runs()}
    assert set(again.calls.values()) == {1}


def test_conflicting_directory_is_refused(tmp_path):
    sweep = small_sweep(tmp_path)
    run_sweep(sweep, SerialBackend(fake_train), log=quiet)
    other = make_sweep(
        "smoke", configs=["E1S1"], algos=["a2c"], seeds=[0], steps=123, out=sweep.out
    )
    with pytest.raises(SweepError, match="another configuration"):
        run_sweep(other, SerialBackend(fake_train), log=quiet)


def test_a_sweep_runs_under_one_driver_at_a_time(tmp_path):
    sweep = small_sweep(tmp_path)
    busy = pytest.raises(SweepError, match=f"being run by pid {os.getpid()}")
    with sweep_lock(sweep.out), busy:
        run_sweep(sweep, SerialBackend(fake_train), log=quiet)
    assert run_sweep(sweep, SerialBackend(fake_train), log=quiet).complete


def test_failed_run_is_reported_and_the_sweep_goes_on(tmp_path):
    sweep = small_sweep(tmp_path, configs=["E1S1"], algos=["a2c"], seeds=[0, 1, 2])

    def runner(task: Job) -> Outcome:
        if task.train["seed"] == 1:
            return Outcome(task.name, "failed", error="ValueError: boom")
        return fake_train(task)

    lines = []
    result = run_sweep(sweep, SerialBackend(runner), log=lines.append)
    assert [o.name for o in result.failed] == ["E1S1/a2c/seed1"]
    assert result.count("done") == 2
    assert any("E1S1/a2c/seed1: FAILED: ValueError: boom" in line for line in lines)


def test_store_result_writes_a_returned_result_once(tmp_path):
    spec = small_sweep(tmp_path).runs()[0]
    run_dir = tmp_path / "driver" / "E1S1"
    result = fake_result(spec.train)
    assert store_result(spec, run_dir, result)
    assert inspect_run(spec, run_dir).kind == DONE
    assert json.loads((run_dir / "config.json").read_text())["algo"] == spec.algo
    assert not store_result(spec, run_dir, result)  # already there: left alone


# -- local processes ---------------------------------------------------------------------------


def test_local_pool_survives_a_dying_worker(tmp_path):
    sweep = small_sweep(tmp_path, configs=["E1S1"], algos=["a2c"], seeds=[0, 1, 2, 3])
    backend = LocalBackend(2, runner=crash_on_seed1, log=quiet)
    result = run_sweep(sweep, backend, log=quiet)
    assert [o.name for o in result.failed] == ["E1S1/a2c/seed1"]
    assert "worker process died (exit code 3)" in result.failed[0].error
    assert result.count("done") == 3
    assert sweep_states(sweep)[sweep.runs()[1]].kind == PENDING


def cli_main():
    """``multicrane benchmark`` through its subcommand module: a parser, ``register``, the
    parsed action's ``func``."""
    from multicrane.cli.benchmark import main

    return main


REAL = ["--profile", "smoke", "--configs", "E1S1", "E2S2", "--algos", "a2c", "ppo"]


def test_ctrl_c_stops_the_running_runs_and_starts_no_more(tmp_path):
    sweep = small_sweep(tmp_path, configs=["E1S1"], algos=["a2c"], seeds=[0, 1, 2, 3])
    timer = threading.Timer(1.5, os.kill, (os.getpid(), signal.SIGINT))  # the driver only
    timer.start()
    try:
        result = run_sweep(sweep, LocalBackend(2, runner=wait_for_sigterm, log=quiet), log=quiet)
    finally:
        timer.cancel()
    assert result.interrupted and result.count("done") == 0
    assert sorted(o.name for o in result.outcomes) == ["E1S1/a2c/seed0", "E1S1/a2c/seed1"]
    assert result.count("stopped") == 2
    kinds = [sweep_states(sweep)[spec].kind for spec in sweep.runs()]
    assert kinds == [PARTIAL, PARTIAL, PENDING, PENDING]


@pytest.fixture(scope="module")
def real_sweep(tmp_path_factory):
    """2 configurations x 2 algorithms x 1 seed x the smoke budget (1,000 steps; PPO's
    rollout makes it 2,000), trained for real by 2 local worker processes."""
    if not HAVE_TRAINING:
        pytest.skip("needs the train extra (stable-baselines3)")
    out = tmp_path_factory.mktemp("real") / "bench"
    sweep = make_sweep("smoke", configs=["E1S1", "E2S2"], algos=["a2c", "ppo"], out=out)
    start = time.perf_counter()
    result = run_sweep(sweep, LocalBackend(2, log=quiet), log=quiet)
    return sweep, result, time.perf_counter() - start


def test_real_sweep_with_two_workers(real_sweep):
    sweep, result, _seconds = real_sweep
    assert result.complete, [o for o in result.outcomes if o.status != "done"]
    for spec in sweep.runs():
        stored = json.loads((spec.dir(sweep.out) / "result.json").read_text())
        assert stored["config"]["algo"] == spec.algo and stored["steps"] >= 1000
        assert stored["curve"][0]["step"] == 0 and stored["final"]["optimal_mean"] is not None
    assert run_sweep(sweep, LocalBackend(2, log=quiet), log=quiet).done_before == 4


def _docs(tmp_path: Path) -> Path:
    docs = tmp_path / "docs" / "benchmark.md"
    docs.parent.mkdir()
    docs.write_text(
        "# Benchmark\n\nintro\n\n<!-- benchmark:smoke:begin -->\nold\n"
        "<!-- benchmark:smoke:end -->\n\ntail\n"
    )
    return docs


def test_report_fills_the_docs_section(real_sweep, tmp_path):
    sweep = real_sweep[0]
    docs = _docs(tmp_path)
    args = ["report", *REAL, "--out", str(sweep.out), "--docs", "--docs-file", str(docs)]
    for _ in range(2):  # the second report replaces the generated section
        assert cli_main()([*args, "--no-plots"]) == 0
    text = docs.read_text()
    assert text.startswith("# Benchmark\n\nintro\n") and text.rstrip().endswith("tail")
    assert text.count("<!-- benchmark:smoke:begin") == 1 and "\nold\n" not in text
    assert "| E2S2 |" in text and "Runs: 4 of 4 finished" in text
    report = (sweep.out / "report.md").read_text()
    assert report.startswith("# Benchmark results: `smoke` sweep")
    summary = json.loads((sweep.out / "summary.json").read_text())
    assert len(summary["cells"]) == 4


@pytest.mark.skipif(not HAVE_MATPLOTLIB, reason="no matplotlib (pip install 'multicrane[bench]')")
def test_report_draws_the_learning_curves(real_sweep, tmp_path):
    sweep = real_sweep[0]
    docs = _docs(tmp_path)
    args = ["report", *REAL, "--out", str(sweep.out), "--docs", "--docs-file", str(docs)]
    assert cli_main()(args) == 0
    pngs = sorted((docs.parent / "benchmark").glob("*.png"))
    assert [p.name for p in pngs] == ["smoke-env1.png", "smoke-env2.png"]
    assert all(p.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" for p in pngs)
    assert "![smoke-env1](benchmark/smoke-env1.png)" in docs.read_text()
    assert (sweep.out / "plots" / "smoke-env1.png").exists()


def test_status_and_dry_run_read_files_only(tmp_path, capsys):
    sweep = small_sweep(tmp_path)
    run_sweep(sweep, SerialBackend(Counting(stop_after=5)), log=quiet)
    main = cli_main()
    common = [
        "--profile",
        "smoke",
        "--configs",
        "E1S1",
        "E2S2",
        "--algos",
        "a2c",
        "ppo",
        "--seeds",
        "0-1",
        "--out",
        str(sweep.out),
    ]
    assert main(["status", *common]) == 0
    out = capsys.readouterr().out
    assert "8 runs: 5 done, 1 partial, 2 pending" in out
    assert "partial: checkpoint at step 500" in out
    assert main(["run", *common, "--dry-run"]) == 0
    assert "dry run: nothing started" in capsys.readouterr().out


def test_profiles_and_a_missing_extra(tmp_path, capsys, monkeypatch):
    main = cli_main()
    assert main(["profiles"]) == 0
    assert [line.split(":")[0] for line in capsys.readouterr().out.splitlines()][::3] == [
        "smoke",
        "quick",
        "standard",
        "paper-budget",
        "paper",
    ]
    sweep = small_sweep(tmp_path)
    sweep.out.mkdir(parents=True)
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # as if not installed
    assert main(["report", "--profile", "smoke", "--out", str(sweep.out)]) == 2
    assert capsys.readouterr().err.strip() == (
        "multicrane benchmark report needs the 'bench' extra: "
        "pip install 'multicrane[bench]' (or --no-plots)"
    )


# -- Ray ---------------------------------------------------------------------------------------


@pytest.fixture
def local_ray(monkeypatch):
    ray = pytest.importorskip("ray", reason="ray not installed (pip install 'multicrane[ray]')")
    monkeypatch.setenv("RAY_AUTH_MODE", "disabled")
    ray.init(
        num_cpus=2,
        include_dashboard=False,
        runtime_env={"env_vars": {"OMP_NUM_THREADS": "1"}},
        log_to_driver=False,
    )
    yield ray
    ray.shutdown()


@pytest.mark.ray
@pytest.mark.long
@pytest.mark.skipif(not HAVE_TRAINING, reason="needs the train extra (stable-baselines3)")
def test_ray_backend_runs_a_tiny_sweep(tmp_path, local_ray):
    from multicrane.benchmark.ray_backend import RayBackend

    sweep = make_sweep("smoke", configs=["E1S1"], algos=["a2c", "ppo"], out=tmp_path / "bench")
    result = run_sweep(sweep, RayBackend(log=quiet), log=quiet)
    assert result.complete, [o for o in result.outcomes if o.status != "done"]
    assert local_ray.is_initialized()  # the caller's instance is left running
    for spec in sweep.runs():
        assert inspect_run(spec, spec.dir(sweep.out)).kind == DONE
    # a result returned by a worker is written by the driver when the file is missing
    spec = sweep.runs()[0]
    path = spec.dir(sweep.out) / "result.json"
    data = json.loads(path.read_text())
    path.unlink()
    assert store_result(spec, spec.dir(sweep.out), data)
    assert inspect_run(spec, spec.dir(sweep.out)).kind == DONE
