"""The ``multicrane`` command: every subcommand on a tiny input, and the base install.

The base install (no torch, no stable-baselines3) runs ``--help`` and ``plan``.
"""

from __future__ import annotations

import gzip
import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from multicrane.cli import COMMANDS, build_parser, main

ROOT = Path(__file__).resolve().parents[2]

# Runs in a fresh interpreter with the optional heavy packages blocked, as after a plain
# ``pip install .``: --help and plan work, commands needing an extra say which one.
_BASE_ONLY = textwrap.dedent(
    """
    import contextlib, importlib.abc, io, sys

    HEAVY = ("torch", "stable_baselines3", "sb3_contrib", "supersuit", "tensorboard", "rerun",
             "matplotlib", "ray", "tqdm")

    class _Block(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in HEAVY:
                raise ModuleNotFoundError(f"No module named {name!r}", name=name)
            return None

    sys.meta_path.insert(0, _Block())
    from multicrane.cli import main

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        try:
            main(["--help"])
        except SystemExit as exc:
            assert exc.code == 0, exc.code
    assert "plan" in out.getvalue() and "train" in out.getvalue(), out.getvalue()
    with contextlib.redirect_stdout(io.StringIO()) as out:
        assert main(["plan", "hall-4c", "--cranes", "4", "--policy", "prioritized"]) == 0
    assert "prioritized" in out.getvalue() and "100%" in out.getvalue(), out.getvalue()
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        assert main(["train", "--paper", "E1S1", "--out", "/nonexistent/run"]) == 2
        assert main(["replay", "bench", "--steps", "5", "--repeats", "1"]) == 2
    assert "multicrane train needs the 'train' extra" in err.getvalue(), err.getvalue()
    assert "pip install 'multicrane[replay]'" in err.getvalue(), err.getvalue()
    loaded = [m for m in sys.modules if m.split(".")[0] in HEAVY]
    assert not loaded, loaded
    print("ok")
    """
)


def _env() -> dict:
    path = os.environ.get("PYTHONPATH", "")
    return dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in (str(ROOT), path) if p))


def test_base_install_runs_help_and_plan_without_heavy_packages():
    out = subprocess.run(
        [sys.executable, "-c", _BASE_ONLY], capture_output=True, text=True, env=_env(), cwd=ROOT
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"


def test_python_dash_m_multicrane_help():
    out = subprocess.run(
        [sys.executable, "-m", "multicrane", "--help"],
        capture_output=True, text=True, env=_env(), cwd=ROOT,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    for name in ("plan", "evaluate", "train", "replay", "check", "bench", "paper-table"):
        assert name in out.stdout


def test_every_subcommand_is_registered():
    parser = build_parser()
    choices = parser._subparsers._group_actions[0].choices  # noqa: SLF001
    for module in COMMANDS:
        if module != "benchmark":  # written on its own branch; listed when present
            assert module.replace("_", "-") in choices


def test_plan_prints_metrics_and_writes_a_record(tmp_path, capsys):
    record = tmp_path / "ep.json.gz"
    argv = ["plan", "e2s2", "--cranes", "2", "--policy", "prioritized", "--record", str(record)]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "scenario e2s2" in out and "prioritized" in out and "100%" in out
    data = json.loads(gzip.decompress(record.read_bytes()))
    assert data["scenario"] == "e2s2" and data["policy"] == "prioritized"
    assert main(["plan", "e1s1", "--policy", "greedy", "random", "--episodes", "2"]) == 0
    assert "random" in capsys.readouterr().out


def test_plan_in_paper_mode_and_refusals(capsys):
    assert main(["plan", "E1S1", "--paper", "--policy", "optimal", "greedy"]) == 0
    out = capsys.readouterr().out
    assert "optimal" in out and "greedy" in out
    assert main(["plan", "E1S1", "--paper", "--policy", "prioritized"]) == 2
    assert "prioritized" in capsys.readouterr().err
    assert main(["plan", "no-such-scenario"]) == 2
    assert "no-such-scenario" in capsys.readouterr().err


def test_evaluate_planners_on_the_same_seeds(tmp_path, capsys):
    out = tmp_path / "eval.json"
    argv = ["evaluate", "--paper", "E1S1", "--policy", "optimal", "random", "--episodes", "2"]
    assert main([*argv, "--seed", "0", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "gap" in text and "optimal" in text
    rows = json.loads(out.read_text())
    assert [[e["seed"] for e in r["episodes"]] for r in rows] == [[0, 1], [0, 1]]
    assert rows[0]["summary"]["gap"] == pytest.approx(0.0, abs=1e-9)
    argv = ["evaluate", "--scenario", "e1s1", "--policy", "prioritized", "--episodes", "1"]
    assert main(argv) == 0


def test_check_accepts_a_scenario_and_rejects_a_broken_file(tmp_path, capsys):
    assert main(["check", "hall-4c"]) == 0
    assert "hall-4c: ok" in capsys.readouterr().out
    bad = tmp_path / "bad.toml"
    bad.write_text((ROOT / "scenarios" / "e1s1.toml").read_text() + "\nsurprise = 1\n")
    assert main(["check", str(bad)]) == 1
    assert "surprise" in capsys.readouterr().out


def test_bench_measures_throughput(capsys):
    assert main(["bench", "--scenario", "e1s1", "--steps", "50"]) == 0
    assert main(["bench", "--paper", "E1S1", "--steps", "50"]) == 0
    out = capsys.readouterr().out
    assert "joint steps/s" in out and "E1S1" in out


def test_paper_table_writes_a_page(tmp_path):
    out = tmp_path / "paper.md"
    argv = ["paper-table", "--configs", "E1S1", "--episodes", "2", "--markdown"]
    assert main([*argv, "--output", str(out)]) == 0
    page = out.read_text()
    assert page.startswith("# Reference returns")
    assert "| E1S1 |" in page and "## Observations" in page
    assert "multicrane paper-table --configs E1S1" in page


def test_compare_planners_text_report(capsys):
    argv = ["compare-planners", "--scenarios", "e1s1", "--cranes", "1", "--seeds", "1"]
    assert main([*argv, "--random-seeds", "0"]) == 0
    out = capsys.readouterr().out
    assert "greedy makespan" in out and "opt+2/comp" in out


def test_train_refuses_bad_settings(tmp_path, capsys):
    pytest.importorskip("stable_baselines3")
    run = tmp_path / "run"
    assert main(["train", "--paper", "E1S1", "--set", "foo=1", "--out", str(run)]) == 2
    assert "foo" in capsys.readouterr().err
    assert not run.exists()


def test_replay_record_and_replay(tmp_path, capsys):
    js = tmp_path / "ep.json"
    argv = ["replay", "record", "--scenario", "e1s1", "--policy", "greedy", "--record", str(js)]
    assert main(argv) == 0
    assert "e1s1" in capsys.readouterr().out
    assert main(["replay", "record", "--scenario", "e1s1"]) == 2  # nothing to write
    pytest.importorskip("rerun")
    assert main(["replay", "replay", str(js), "--rrd", str(tmp_path / "ep.rrd")]) == 0
    assert (tmp_path / "ep.rrd").stat().st_size > 0


def test_help_examples_keep_their_line_breaks():
    """A help text's example wrapped with a single ``\\`` in the source loses its line break
    (Python joins the lines): it shows as one line with a run of spaces before an option."""
    parser = build_parser()
    choices = parser._subparsers._group_actions[0].choices  # noqa: SLF001
    joined = re.compile(r"\S {3,}--?\w")
    for name, sub in choices.items():
        for text in (sub.description or "", sub.epilog or ""):
            bad = [line for line in text.splitlines() if joined.search(line.strip())]
            assert not bad, f"multicrane {name} --help: {bad}"
