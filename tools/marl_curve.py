"""Plot training runs' learning curves (makespan of the evaluation episodes) as a PNG.

    python tools/marl_curve.py RUN_DIR [RUN_DIR ...] OUT.png [--line LABEL=VALUE ...]
        [--against steps|time] [--label LABEL] [--title TITLE] [--reach MAKESPAN]
        [--ymax MAKESPAN]

Reads each RUN_DIR's evaluations during training (``result.json``, or for a run still going
its checkpoint's progress) and draws the mean makespan of the greedy evaluation episodes
against crane decisions trained (``--against time``: training wall time), with horizontal
reference lines (e.g. the prioritized planner and the lower bound). With several runs
(training seeds of one setting, evaluated at the same points) each is a thin line and their
mean a thick one, with the Student-t 95 % interval over seeds as a band. A point where a run
did not finish every evaluation episode is left out of the mean and drawn as a red cross at
the top of the plot. ``--reach MAKESPAN`` also prints, run by run, the first point at or
below that makespan (e.g. a planner's on the same evaluation episodes): its crane decisions
and training wall time, "time to planner". ``--ymax`` cuts the y axis there (the points of
a run that collapsed go off the top). The drawing is ``multicrane.reports.comparison_plot``'s
(the one ``multicrane evaluate --plot`` and ``multicrane seed-table --plot`` use). Needs
matplotlib (the ``bench`` extra).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from multicrane.reports.comparison_data import curve_panel, run_curves
from multicrane.reports.comparison_plot import write_figure


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("paths", type=Path, nargs="+", metavar="RUN_DIR ... OUT.png")
    p.add_argument("--line", action="append", default=[], metavar="LABEL=VALUE")
    p.add_argument("--against", choices=["steps", "time"], default="steps")
    p.add_argument("--label", default="set policy (greedy evaluation)")
    p.add_argument("--title", default=None)
    p.add_argument("--reach", type=float, default=None, metavar="MAKESPAN")
    p.add_argument("--ymax", type=float, default=None, metavar="MAKESPAN")
    args = p.parse_args()
    *runs, out = args.paths
    if not runs:
        p.error("give at least one RUN_DIR and the OUT.png")
    curves = run_curves({args.label: runs}, say=p.error)
    panel = curve_panel(curves, paper=False, against=args.against,
                        title=args.title or runs[0].name)  # fmt: skip
    panel.ymax = args.ymax
    for item in args.line:
        label, _, value = item.partition("=")
        panel.lines.append((label, float(value)))
    write_figure([panel], out)
    points = min(len(run) for run in curves[args.label])
    print(f"wrote {out} ({len(runs)} run(s), {points} points)")
    if args.reach is not None:
        for run_dir, run in zip(runs, curves[args.label], strict=True):
            print(f"{run_dir}: {reached(run, args.reach)}")
    return 0


def reached(run: list[dict], makespan: float) -> str:
    """When the curve first finished every episode in at most ``makespan`` steps on average."""
    for point in run:
        if point.get("success_rate", 1.0) >= 1.0 and point["steps_mean"] <= makespan:
            seconds = point.get("seconds")
            after = f", {seconds:.0f} s" if seconds is not None else ""
            return f"{makespan} reached at {point['step']:,} decisions{after}"
    return f"{makespan} not reached in {run[-1]['step']:,} decisions"


if __name__ == "__main__":
    raise SystemExit(main())
