"""The comparison commands' plots: the panels each command's results become (the points are
the table's episodes, the bars its means and intervals) and the PNG they are drawn into."""

from __future__ import annotations

import json
import struct
import sys

import pytest
from test_seed_table import ROWS

import policies
from multicrane.cli import main
from multicrane.reports.comparison_data import (
    curve_panel,
    evaluate_panels,
    planner_panels,
    run_curves,
    seed_table_panels,
    uncertainty_panels,
)
from multicrane.reports.comparison_plot import (
    BOUND,
    CurvePanel,
    Curves,
    StripPanel,
    curve_mean,
    positions,
    strip,
    write_figure,
)
from multicrane.reports.planners import Setup, run_all
from multicrane.reports.seed_table import entries
from multicrane.reports.uncertainty import Bound, Cell
from multicrane.stats import ci95


def png_size(path) -> tuple[int, int]:
    """(width, height) of a PNG file, read from its header (fails on anything else)."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def assert_plausible_png(path, max_kb: int = 300) -> None:
    width, height = png_size(path)
    assert 250 <= width <= 4000 and 200 <= height <= 4000
    assert 5_000 < path.stat().st_size < max_kb * 1000


def _episode(scenario, seed, makespan, ret=-1.0, **extra):
    return {"scenario": scenario, "n_cranes": 2, "seed": seed, "success": makespan is not None,
            "makespan": makespan, "return": ret, **extra}  # fmt: skip


def test_evaluate_points_are_each_policys_episodes_one_panel_per_site():
    rows = [
        {"policy": "prioritized", "episodes": [_episode("a", 0, 30), _episode("a", 1, 34),
                                               _episode("b", 0, 50)]},
        {"policy": "random", "episodes": [_episode("a", 0, None), _episode("a", 1, 90),
                                          _episode("b", 0, None)]},
    ]  # fmt: skip
    panels = evaluate_panels(rows, paper=False)
    assert [p.title for p in panels] == ["a", "b"]
    a = {s.label: s for s in panels[0].strips}
    assert a["prioritized"].seeds == [[30, 34]] and a["random"].seeds == [[None, 90]]
    assert a["prioritized"].mean == 32.0 and a["prioritized"].interval == ci95([30, 34])
    assert a["random"].values == [90] and a["random"].episodes == 2  # drawn as "1/2 done"
    assert panels[1].strips[1].mean is None and panels[1].strips[1].interval is None


def test_paper_mode_plots_returns_beside_the_exact_planners():
    rows = [{"policy": "ppo (run)", "episodes": [
        _episode("E1S1", s, 20, ret=r, optimal_return=o)
        for s, r, o in ((0, -3.0, -1.0), (1, -5.0, -2.0))]}]  # fmt: skip
    (panel,) = evaluate_panels(rows, paper=True)
    learned, best = panel.strips
    assert learned.seeds == [[-3.0, -5.0]] and learned.mean == -4.0
    assert best.label == "optimal" and best.kind == BOUND and best.seeds == [[-1.0, -2.0]]
    assert panel.ylabel == "return"
    played = [*rows, {"policy": "optimal", "episodes": rows[0]["episodes"]}]
    assert [s.label for s in evaluate_panels(played, paper=True)[0].strips] == [
        "ppo (run)", "optimal"]  # the exact planner's row: not twice  # fmt: skip


def test_seed_table_points_are_the_tables_episodes_and_seed_means():
    table = entries(ROWS)
    bounds = [80, 85, 90]
    (panel,) = seed_table_panels(table, ["e2s2"] * 3, bounds)
    learned, planner, _, bound = panel.strips
    assert learned.seeds == [[100, 110, 120], [90, None, 100]]  # per training seed
    assert learned.seed_means == table[0].per_seed == [110.0, 95.0]
    assert (learned.mean, learned.interval) == (table[0].mean, table[0].ci)  # over seeds
    assert planner.seeds == [[95, 105, 100]] and planner.seed_means == []
    assert (planner.mean, planner.interval) == (table[1].mean, table[1].ci)
    assert bound.kind == BOUND and bound.seeds == [bounds]
    two = seed_table_panels(table, ["x", "y", "x"], None)  # one panel per site
    assert [p.title for p in two] == ["x", "y"]
    assert two[0].strips[0].seeds == [[100, 120], [90, 100]] and len(two[0].strips) == 3


def test_planner_points_are_each_cells_episodes_with_their_bounds():
    setup = Setup(["e1s1"], [1, 2], ["greedy", "random"], seeds=2, random_seeds=1,
                  optimal=False, bound_time_limit=5.0, task_cost=False)  # fmt: skip
    makers = {name: policies.factory(name, paper=False) for name in setup.policies}
    results = run_all(setup, makers)
    (panel,) = planner_panels(results)
    assert [(s.cluster, s.label) for s in panel.strips] == [
        (c, p) for c in ("1 crane", "2 cranes") for p in ("greedy", "random", "bound")
    ]
    for s in panel.strips:
        n = int(s.cluster[0])
        if s.kind == BOUND:
            assert s.seeds == [results.bounds["e1s1", n].values]
        else:
            cell = results.cells["e1s1", n, s.label]
            assert s.seeds == [[r["makespan"] for r in cell.results]]
            assert s.mean == cell.summary["makespan_mean"]


def test_uncertainty_puts_the_levels_side_by_side_per_policy():
    cells = [
        Cell("e2s2", 2, level, policy, [0, 1000], spans)
        for level, spans in (("none", [30, 30]), ("high", [80, None]))
        for policy in ("static-plan", "replanning")
    ]
    bounds = [Bound("e2s2", 2, [27, 28], ["OPTIMAL", "OPTIMAL"])]
    (panel,) = uncertainty_panels(cells, bounds)
    assert panel.title == "e2s2 (2 cranes)"
    assert [(s.cluster, s.label) for s in panel.strips] == [
        ("static-plan", "none"), ("static-plan", "high"), ("replanning", "none"),
        ("replanning", "high"), ("bound", "undisturbed")]  # fmt: skip
    high = panel.strips[1]
    assert high.seeds == [[80, None]] and high.mean == cells[2].mean and high.kind == "high"
    assert panel.strips[-1].seeds == [[27, 28]]


def test_columns_of_a_cluster_stand_together():
    strips = [strip(p, [1], cluster=c) for c, p in (("1", "a"), ("1", "b"), ("2", "a"))]
    assert positions(strips) == [0.0, 1.0, 3.0]
    assert positions([strip("a", [1]), strip("b", [2])]) == [0.0, 1.0]


def _run_dir(tmp_path, name, points):
    run = tmp_path / name
    run.mkdir()
    (run / "result.json").write_text(json.dumps({"curve": points}))
    return run


def _point(step, seconds, steps_mean, success=1.0, ret=-2.0):
    return {"step": step, "seconds": seconds, "steps_mean": steps_mean,
            "success_rate": success, "return_mean": ret}  # fmt: skip


def test_learning_curves_against_wall_time(tmp_path):
    a = _run_dir(tmp_path, "r-s0", [_point(0, 1.0, 100), _point(500, 9.0, 80, success=0.5)])
    b = _run_dir(tmp_path, "r-s1", [_point(0, 2.0, 90), _point(500, 11.0, 70)])
    curves = run_curves({"r": [a, b]})
    panel = curve_panel(curves, paper=False)
    assert panel.xlabel == "training wall time (s)"
    assert panel.groups[0].runs == [[(1.0, 100), (9.0, None)], [(2.0, 90), (11.0, 70)]]
    xs, mean, low, high = curve_mean(panel.groups[0].runs)
    assert xs == [1.5, 10.0] and mean == [95.0, 70.0]  # a point without a value: left out
    assert (low[0], high[0]) == ci95([100, 90]) and low[1] == high[1] == 70.0
    paper = curve_panel(curves, paper=True, against="steps")
    assert paper.groups[0].runs[0] == [(0, -2.0), (500, -2.0)]
    assert paper.xlabel == "timesteps trained"


def test_runs_without_wall_time_are_plotted_against_steps_and_unreadable_ones_left_out(tmp_path):
    old = _run_dir(tmp_path, "old", [{"step": 10, "steps_mean": 5.0, "return_mean": 0.0}])
    said = []
    curves = run_curves({"old": [old], "gone": [tmp_path / "nowhere"]}, say=said.append)
    assert list(curves) == ["old"] and "learning curves of gone: left out" in said[0]
    panel = curve_panel(curves, paper=False)
    assert panel.groups[0].runs == [[(10, 5.0)]]
    assert panel.xlabel.endswith("no wall time recorded")


def test_figure_of_strips_and_curves_is_a_png(tmp_path):
    pytest.importorskip("matplotlib")
    strips = [strip("prioritized", [30, 32, 31]), strip("random", [None, 90]),
              strip("bound", [27, 28, 27], kind=BOUND)]  # fmt: skip
    seeds = StripPanel("e2s2", strips, "makespan")
    curves = CurvePanel("curves", [Curves("ppo", [[(0, 50), (5, None)], [(0, 40), (6, 35)]])],
                        "s", "makespan", [("bound", 27.0)])  # fmt: skip
    path = write_figure([seeds, curves], tmp_path / "deep" / "plot.png", "a title")
    assert path == tmp_path / "deep" / "plot.png"
    assert_plausible_png(path)
    with pytest.raises(ValueError, match="nothing to plot"):
        write_figure([], tmp_path / "none.png")


def test_ymax_cuts_the_axis_at_the_lowest_point_and_the_given_top():
    pytest.importorskip("matplotlib")
    from matplotlib.figure import Figure

    from multicrane.reports.comparison_plot import _draw_curves

    collapsed = [[(0, 160), (1, 130), (2, 500)], [(0, 150), (1, 128), (2, 127)]]
    for ymax, expected in ((175.0, (127 * 0.97, 175.0)), (None, None)):
        ax = Figure().add_subplot()
        _draw_curves(ax, CurvePanel("c", [Curves("ppo", collapsed)], "s", "makespan",
                                    ymax=ymax), {"ppo": "C0"})  # fmt: skip
        low, high = ax.get_ylim()
        if expected is None:  # automatic: the whole band shows, the collapsed point too
            assert low < 127 and high > 500
        else:
            assert (low, high) == pytest.approx(expected)


def test_without_matplotlib_the_command_names_the_extra_at_once(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib fails
    argv = ["uncertainty", "--scenarios", "e2s2:2", "--levels", "none", "--seeds", "1",
            "--bound-time", "0", "--plot", str(tmp_path / "u.png")]  # fmt: skip
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert "needs the 'bench' extra" in captured.err and len(captured.err.splitlines()) == 1
    assert captured.out == ""  # said before any episode
    assert not (tmp_path / "u.png").exists()
