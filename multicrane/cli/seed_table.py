"""``multicrane seed-table``: learned runs pooled over training seeds beside the planners."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from multicrane.cli.common import error, formatter

DESCRIPTION = """Summarise a `multicrane evaluate --json` file: run directories named PREFIX-sN
(one training seed each) become one row, the mean over training seeds of each seed's mean
makespan with the Student-t 95 % interval over seeds; planners are rows of their own (interval
over episodes). Also: finished episodes, how many seeds finished every episode, each seed's
mean, the ratio to --baseline and the share of episodes where the learned policy is shorter
than it on the same reset seed, and, unless --bound-time 0, the proven lower bound of every
episode (multicrane bound, CP-SAT) with each row's gap to its mean.

    multicrane evaluate --scenario hall-4c --cranes 4 --decisions task --episodes 50 \\
        --policy runs/hall-s0 runs/hall-s1 runs/hall-s2 prioritized greedy --json ev.json
    multicrane seed-table ev.json --out table.md
    multicrane evaluate --scenario set:test-small --decisions task --episodes 1 \\
        --policy runs/hall-s0 prioritized --json small.json
    multicrane seed-table small.json --sites set:test-small   # bounds of the set's sites
    multicrane seed-table ev.json --plot table.png

--plot FILE.png draws what the table summarises, one panel per site: every episode's makespan
per row (a learned row: its training seeds' episodes, each seed's mean as a diamond), the
row's mean with its 95 % interval, the episodes' bounds; and the learning curves of the run
directories (those the evaluate --json file names that are still on disk) against training
wall time (matplotlib: the 'bench' extra).
"""


def register(sub) -> None:
    p = sub.add_parser("seed-table", help="learned runs over training seeds beside planners",
                       description=DESCRIPTION, **formatter())  # fmt: skip
    p.add_argument("results", type=Path, help="a multicrane evaluate --json file")
    p.add_argument("--baseline", default="prioritized", help="the planner compared against")
    p.add_argument("--bound-time", type=float, default=10.0,
                   help="CP-SAT seconds per episode's bound (0: no bound)")  # fmt: skip
    p.add_argument("--bound-workers", type=int, default=1,
                   help="CP-SAT workers per bound (more prove the relaxation sooner)")  # fmt: skip
    p.add_argument("--sites", default=None, metavar="set:NAME",
                   help="the scenario set the episodes were played on (to bound them)")  # fmt: skip
    p.add_argument("--bounds", type=Path, default=None,
                   help="reuse the bounds an earlier --out wrote (OUT.bounds.json)")  # fmt: skip
    p.add_argument("--out", type=Path, default=None,
                   help="write the markdown table, and the bounds as OUT.bounds.json")  # fmt: skip
    p.add_argument("--plot", type=Path, metavar="FILE.png",
                   help="also draw the episodes per row and the runs' learning curves")  # fmt: skip
    p.set_defaults(func=run)


def episode_bounds(rows, time_limit: float, sites: str | None = None, workers: int = 1
                   ) -> list[int]:  # fmt: skip
    """The proven makespan lower bound of every episode the rows played (``workers`` CP-SAT
    workers); ``sites``: the ``set:NAME`` whose members the episodes' scenario names are."""
    from multicrane.bounds.makespan import lower_bound

    named = {}
    if sites is not None:
        from multicrane.scenario.named_sets import resolve_set

        named = {name.split("/")[-1]: scenario for name, scenario in resolve_set(sites)}
    return [
        lower_bound(named.get(e["scenario"], e["scenario"]), e["n_cranes"], e["seed"],
                    time_limit, workers=workers).value
        for e in rows[0]["episodes"]
    ]  # fmt: skip


def run(args: argparse.Namespace) -> int:
    import multicrane
    from multicrane.reports.seed_table import entries, markdown_table

    if args.plot is not None:
        from multicrane.reports.comparison_plot import require_matplotlib

        require_matplotlib()  # before the bounds: a missing extra is said at once
    try:
        rows = json.loads(args.results.read_text())
        table_entries = entries(rows)
    except OSError as exc:
        return error(f"{args.results}: {exc.strerror or exc}")
    except json.JSONDecodeError as exc:
        return error(f"{args.results}: not JSON ({exc})")
    except (KeyError, TypeError, IndexError) as exc:
        return error(f"{args.results}: not a multicrane evaluate --json file (missing {exc})")
    except ValueError as exc:
        return error(f"{args.results}: {exc}")
    if not table_entries:
        return error(f"{args.results}: no policies in it")
    bounds = None
    if args.bounds is not None:
        try:
            saved = json.loads(args.bounds.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            return error(f"{args.bounds}: {exc}")
        episodes = [[e["scenario"], e["seed"]] for e in rows[0]["episodes"]]
        if saved.get("episodes") != episodes:
            return error(f"{args.bounds}: bounds of other episodes than {args.results}'s")
        bounds = saved["bounds"]
    elif args.bound_time > 0:
        if args.bound_workers < 1:
            return error(f"--bound-workers {args.bound_workers}: must be at least 1")
        try:
            bounds = episode_bounds(rows, args.bound_time, args.sites, args.bound_workers)
        except (multicrane.ScenarioError, ValueError) as exc:
            return error(f"{args.results}: cannot bound its episodes: {exc}")
    table = markdown_table(table_entries, args.baseline, bounds)
    first = rows[0]["episodes"]
    heading = what_was_played(first, args.sites)
    print(heading)
    print(table)
    if args.out is not None:
        args.out.write_text(table + "\n")
        if bounds is not None:
            seeds = [e["seed"] for e in first]
            episodes = [[e["scenario"], e["seed"]] for e in first]
            args.out.with_suffix(".bounds.json").write_text(
                json.dumps({"seeds": seeds, "episodes": episodes, "bounds": bounds}) + "\n"
            )
    if args.plot is not None:
        print(f"plot: {plot(rows, table_entries, bounds, args.plot, heading)}")
    return 0


def what_was_played(episodes: list[dict], sites: str | None) -> str:
    """The table's heading: the scenario, cranes, episodes and seeds (or the set's sites)."""
    names = sorted({e["scenario"] for e in episodes})
    if len(names) > 1:
        return f"{sites or 'several scenarios'}: {len(episodes)} episodes on {len(names)} sites"
    first, last = episodes[0], episodes[-1]
    return (f"{names[0]}, {first['n_cranes']} cranes, {len(episodes)} episodes "
            f"(reset seeds {first['seed']}..{last['seed']})")  # fmt: skip


def plot(rows: list[dict], table_entries: list, bounds: list[int] | None, path: Path,
         title: str) -> Path:  # fmt: skip
    """The table's episodes per row, and the learning curves of the run directories on disk
    (one group per learned row: its training seeds), as a PNG."""
    from multicrane.reports.comparison_data import curve_panel, run_curves, seed_table_panels
    from multicrane.reports.comparison_plot import write_figure

    scenarios = [e["scenario"] for e in rows[0]["episodes"]]
    panels: list = seed_table_panels(table_entries, scenarios, bounds)
    run_of = {row["policy"]: row["run"] for row in rows if "run" in row}
    runs = {e.name: [run_of[n] for n in e.seeds if n in run_of] for e in table_entries}
    curves = run_curves({name: paths for name, paths in runs.items() if paths})
    if curves:
        panels.append(curve_panel(curves, paper=False))
    return write_figure(panels, path, title)
