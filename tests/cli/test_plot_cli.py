"""``--plot FILE.png`` of the comparison commands: evaluate, seed-table, compare-planners and
uncertainty each write a PNG of what their table summarises (small runs)."""

from __future__ import annotations

import json

import pytest
from test_comparison_plot import assert_plausible_png

from multicrane.cli import main

pytest.importorskip("matplotlib")


def test_evaluate_and_seed_table_plot_the_episodes(tmp_path, capsys):
    results, plot = tmp_path / "ev.json", tmp_path / "ev.png"
    argv = ["evaluate", "--scenario", "e2s2", "--cranes", "2", "--policy", "prioritized",
            "random", "--episodes", "2", "--seed", "0", "--json", str(results),
            "--plot", str(plot)]  # fmt: skip
    assert main(argv) == 0
    assert f"plot: {plot}" in capsys.readouterr().out
    assert_plausible_png(plot)
    rows = json.loads(results.read_text())
    assert all(len(r["episodes"]) == 2 and "run" not in r for r in rows)  # planners: no run
    table_plot = tmp_path / "table.png"
    argv = ["seed-table", str(results), "--bound-time", "1", "--plot", str(table_plot)]
    assert main(argv) == 0
    assert f"plot: {table_plot}" in capsys.readouterr().out
    assert_plausible_png(table_plot)


def test_compare_planners_plot_and_its_page_section(tmp_path, capsys):
    plot, page = tmp_path / "plots" / "planners.png", tmp_path / "page" / "planners.md"
    argv = ["compare-planners", "--scenarios", "e1s1", "--cranes", "1", "2", "--seeds", "2",
            "--random-seeds", "1", "--no-optimal", "--bound-time-limit", "2", "--markdown",
            "--output", str(page), "--plot", str(plot)]  # fmt: skip
    assert main(argv) == 0
    assert f"plot: {plot}" in capsys.readouterr().err
    assert_plausible_png(plot)
    assert "![makespan of every episode](../plots/planners.png)" in page.read_text()


def test_uncertainty_plot_beside_its_out_directory(tmp_path, capsys):
    plot, out = tmp_path / "u.png", tmp_path / "out"
    argv = ["uncertainty", "--scenarios", "e2s2:2", "--levels", "none", "high", "--seeds", "2",
            "--policies", "static-plan", "replanning", "--bound-time", "0",
            "--plot", str(plot), "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    assert f"plot: {plot}" in capsys.readouterr().out
    assert_plausible_png(plot)
    assert plot.read_bytes() == (out / "uncertainty.png").read_bytes()  # one drawing
