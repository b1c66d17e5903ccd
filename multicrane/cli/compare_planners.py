"""``multicrane compare-planners``: classical planners on the shipped scenarios with 1-4 cranes."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from multicrane.cli import progress
from multicrane.cli.common import formatter

DESCRIPTION = """Classical multi-crane planners on every shipped scenario with 1-4 cranes: the
baselines RL must beat.

    multicrane compare-planners                                  # text tables
    multicrane compare-planners --markdown --output docs/planners.md
    multicrane compare-planners --scenarios hall-4c frame2-3c --cranes 1 4 --seeds 3
    multicrane compare-planners --scenarios set:test-small --cranes 2 --no-bound --no-optimal

A named scenario set (``set:NAME``, see ``multicrane.scenario.named_sets``; ``set:train:A-B`` for
train seeds A..B-1) stands for its sites, each a row of the tables.

For each scenario (default: all) and crane count (default 1 2 3 4) it plays, in the claiming
mode, the episodes reset(seed=first + i) starts: greedy and prioritized (--seeds episodes),
random (--random-seeds episodes, seeded per episode with (seed, 1)), and for the paper's
configurations (e?s?) with one crane the exact single-agent optimum on the same layouts.
Metrics: makespan, success rate, blocked moves, crane utilisation and planning time per
decision. Progress goes to stderr.

--plot FILE.png draws every episode's makespan, one panel per scenario, a cluster per crane
count: a column per policy (the mean and its 95 % interval beside the dots) and the episodes'
lower bounds (matplotlib: the 'bench' extra); with --markdown the page shows it.
"""

POLICIES = ("greedy", "prioritized", "random")


def register(sub) -> None:
    p = sub.add_parser("compare-planners", help="compare the classical planners",
                       description=DESCRIPTION, **formatter())  # fmt: skip
    p.add_argument("--scenarios", nargs="+", default=None,
                   help="shipped names or set:NAME (default: every shipped one)")  # fmt: skip
    p.add_argument("--cranes", nargs="+", type=int, default=[1, 2, 3, 4])
    p.add_argument("--policies", nargs="+", default=list(POLICIES), choices=POLICIES)
    p.add_argument("--seeds", type=int, default=5, help="episodes per setting (planners)")
    p.add_argument("--random-seeds", type=int, default=2, help="episodes per setting (random)")
    p.add_argument("--seed", type=int, default=0, help="first episode seed")
    p.add_argument("--no-optimal", dest="optimal", action="store_false")
    p.add_argument("--no-bound", dest="bound", action="store_false",
                   help="skip the CP-SAT lower bound of each episode")  # fmt: skip
    p.add_argument("--bound-time-limit", type=float, default=60.0, help="seconds per bound")
    p.add_argument("--no-task", dest="task", action="store_false",
                   help="skip task-mode prioritized on the large scenarios")  # fmt: skip
    p.add_argument("--markdown", action="store_true", help="print a whole markdown page")
    p.add_argument("--output", type=Path, help="write the report here instead of stdout")
    p.add_argument("--plot", type=Path, metavar="FILE.png",
                   help="also draw every episode's makespan per policy and the bounds")  # fmt: skip
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    import multicrane
    import policies
    from multicrane.cli.common import error
    from multicrane.files import write_atomic
    from multicrane.reports.planners import Setup, run_all
    from multicrane.reports.planners_page import markdown_page, text_report
    from multicrane.reports.provenance import command_line
    from multicrane.scenario.named_sets import is_set_ref, resolve_set

    names = multicrane.scenario_names()
    scenarios, sites = [], {}
    for ref in args.scenarios or names:
        if is_set_ref(ref):
            try:
                members = resolve_set(ref)
            except ValueError as e:
                return error(str(e))
            sites.update(members)
            scenarios += [name for name, _ in members]
        else:
            scenarios.append(ref)
    unknown = [s for s in scenarios if s not in names and s not in sites]
    if unknown:
        return error(f"unknown scenario(s): {', '.join(unknown)}")
    if args.seeds < 1:
        return error("--seeds must be at least 1")
    if args.plot is not None:
        from multicrane.reports.comparison_plot import require_matplotlib

        require_matplotlib()  # before the episodes: a missing extra is said at once
    setup = Setup(scenarios, args.cranes, args.policies, args.seeds, args.random_seeds,
                  args.seed, args.optimal, args.bound, args.bound_time_limit,
                  args.task, sites)  # fmt: skip
    makers = {name: policies.factory(name, paper=False) for name in args.policies}
    with progress.bar(setup.episodes(), "compare-planners") as advance:
        quiet = progress.enabled()
        results = run_all(
            setup, makers, policies.factory("optimal", paper=True), advance,
            log=None if quiet else (lambda line: print(line, file=sys.stderr, flush=True)),
        )  # fmt: skip
    if args.plot is not None:
        print(f"plot: {plot(results, args.plot)}", file=sys.stderr)
    if args.markdown:
        report = markdown_page(results, command_line(args.argv))
        if args.plot is not None:
            report += plot_section(args.plot, args.output)
    else:
        report = text_report(results)
    report += "" if report.endswith("\n") else "\n"
    if args.output:
        args.output.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(args.output, report)
        print(f"wrote {args.output}", file=sys.stderr)
    else:
        sys.stdout.write(report)
    return 0


def plot(results, path: Path) -> Path:
    """Every episode's makespan per scenario, crane count and policy, and the bounds."""
    from multicrane.reports.comparison_data import planner_panels
    from multicrane.reports.comparison_plot import write_figure

    return write_figure(planner_panels(results), path)


def plot_section(plot: Path, page: Path | None) -> str:
    """The page's section that shows the plot (its path relative to the page's folder)."""
    where = Path(os.path.relpath(plot, page.parent)) if page is not None else plot
    return (
        "\n## Every episode\n\nEach dot one episode's makespan (jittered sideways), the black "
        "bar the mean with its 95 % interval, a black dash each episode's lower bound; "
        f"in red *done/episodes* atop a column that did not finish every episode.\n\n"
        f"![makespan of every episode]({where.as_posix()})\n"
    )
