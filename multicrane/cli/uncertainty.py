"""``multicrane uncertainty``: makespan and completion of planners under disruption levels."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from multicrane.cli.common import error, formatter, trained_decisions

DESCRIPTION = """Play policies on sites with events (late deliveries, crane breakdowns, closed
zones; docs/uncertainty.md) at disruption levels none / low / high and report, per scenario x
level x policy, the completion rate and the makespan of the completed episodes (mean and 95 %
confidence interval), beside the undisturbed site's proven lower bound (OR-Tools CP-SAT).

    multicrane uncertainty
    multicrane uncertainty --scenarios e2s2:2 --levels none high --seeds 3 --out runs/unc

A scenario may name its crane count after a colon (e2s2:2); else --cranes, else its own.

Policies (--policies): static-plan (one plan at reset for the undisturbed site, executed in
order), replanning (the prioritized planner, which notices events and replans), greedy,
random, or a trained run directory (a task-level run, e.g. the set policy trained with
multicrane train --decisions task --policy set --events low, plays with task decisions;
makespans are simulated steps either way). Episodes start from reset seeds 1000 * s + e. --out
writes results.json (every episode's makespan), table.md and uncertainty.png, the plot that
--plot FILE.png draws: one panel per scenario, per policy its levels side by side, every
episode's makespan a dot beside the mean and its 95 % interval, and the undisturbed site's
bounds (matplotlib: the 'bench' extra). One process; --bound-time 0 skips the bound.
"""

DEFAULT_SCENARIOS = ("e2s2:2", "frame2-3c", "hall-4c")
DEFAULT_POLICIES = ("static-plan", "replanning", "greedy")


def register(sub) -> None:
    p = sub.add_parser("uncertainty", help="planners under late deliveries, breakdowns, closures",
                       description=DESCRIPTION, **formatter())  # fmt: skip
    p.add_argument("--scenarios", nargs="+", default=list(DEFAULT_SCENARIOS),
                   help="shipped scenario names or .toml paths")  # fmt: skip
    p.add_argument("--levels", nargs="+", default=["none", "low", "high"],
                   choices=["none", "low", "high"], help="disruption levels")  # fmt: skip
    p.add_argument("--policies", nargs="+", default=list(DEFAULT_POLICIES))
    p.add_argument("--seeds", type=int, default=5, help="seeds per cell")
    p.add_argument("--episodes", type=int, default=1, help="episodes per seed")
    p.add_argument("--cranes", type=int, default=None, help="crane count (default: scenario's)")
    p.add_argument("--bound-time", type=float, default=10.0,
                   help="CP-SAT seconds per bound (0: no bound)")  # fmt: skip
    p.add_argument("--out", default=None, help="directory for results.json, table.md, the plot")
    p.add_argument("--plot", type=Path, metavar="FILE.png",
                   help="also draw every episode's makespan per policy and level here")  # fmt: skip
    p.set_defaults(func=run)


def scenario_and_cranes(text: str, cranes: int | None):
    """``name`` or ``name:N`` -> (Scenario, crane count or None)."""
    import multicrane

    name, sep, count = text.rpartition(":")
    if not sep or not count.isdigit():
        return multicrane.load_scenario(text), cranes
    return multicrane.load_scenario(name), int(count)


def run(args: argparse.Namespace) -> int:
    import multicrane
    import policies
    from multicrane.reports.uncertainty import episode_seeds, markdown_table, run_benchmark

    try:
        seeds = episode_seeds(args.seeds, args.episodes)
        factories = {name: policies.factory(name, paper=False) for name in args.policies}
        scenarios = [scenario_and_cranes(name, args.cranes) for name in args.scenarios]
    except (ValueError, multicrane.ScenarioError, OSError) as exc:
        return error(exc, 1)
    if args.plot is not None or args.out is not None:
        from multicrane.reports.comparison_plot import require_matplotlib

        require_matplotlib()  # before the episodes: a missing extra is said at once
    makers = {f.label: f for f in factories.values()}
    decisions = {f.label: trained_decisions(f) for f in factories.values()}
    began = time.perf_counter()
    cells, bounds = run_benchmark(
        scenarios, args.levels, makers, seeds, args.bound_time,
        progress=lambda line: print(line, flush=True), decisions=decisions,
    )  # fmt: skip
    wall = time.perf_counter() - began
    table = markdown_table(cells, bounds)
    print(table)
    print(f"wall time {wall:.0f} s")
    plots = [] if args.plot is None else [args.plot]
    if args.out is not None:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        data = {"argv": getattr(args, "argv", None), "wall_s": wall,
                "cells": [c.as_dict() for c in cells],
                "bounds": [b.__dict__ for b in bounds]}  # fmt: skip
        (out / "results.json").write_text(json.dumps(data, indent=1) + "\n")
        (out / "table.md").write_text(table + "\n")
        plots.append(out / "uncertainty.png")
    if plots:
        from multicrane.reports.comparison_data import uncertainty_panels
        from multicrane.reports.comparison_plot import write_figure

        panels = uncertainty_panels(cells, bounds)
        for path in plots:
            print(f"plot: {write_figure(panels, path)}")
    return 0
