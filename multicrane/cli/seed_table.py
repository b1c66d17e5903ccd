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
    multicrane evaluate --scenario set:test-small --decisions task --episodes 1 \
        --policy runs/hall-s0 prioritized --json small.json
    multicrane seed-table small.json --sites set:test-small   # bounds of the set's sites
"""


def register(sub) -> None:
    p = sub.add_parser("seed-table", help="learned runs over training seeds beside planners",
                       description=DESCRIPTION, **formatter())  # fmt: skip
    p.add_argument("results", type=Path, help="a multicrane evaluate --json file")
    p.add_argument("--baseline", default="prioritized", help="the planner compared against")
    p.add_argument("--bound-time", type=float, default=10.0,
                   help="CP-SAT seconds per episode's bound (0: no bound)")  # fmt: skip
    p.add_argument("--sites", default=None, metavar="set:NAME",
                   help="the scenario set the episodes were played on (to bound them)")  # fmt: skip
    p.add_argument("--bounds", type=Path, default=None,
                   help="reuse the bounds an earlier --out wrote (OUT.bounds.json)")  # fmt: skip
    p.add_argument("--out", type=Path, default=None,
                   help="write the markdown table, and the bounds as OUT.bounds.json")  # fmt: skip
    p.set_defaults(func=run)


def episode_bounds(rows, time_limit: float, sites: str | None = None) -> list[int]:
    """The proven makespan lower bound of every episode the rows played (one CP-SAT worker);
    ``sites``: the ``set:NAME`` whose members the episodes' scenario names are."""
    from multicrane.bounds.makespan import lower_bound

    named = {}
    if sites is not None:
        from multicrane.scenario.named_sets import resolve_set

        named = {name.split("/")[-1]: scenario for name, scenario in resolve_set(sites)}
    return [
        lower_bound(named.get(e["scenario"], e["scenario"]), e["n_cranes"], e["seed"],
                    time_limit, workers=1).value
        for e in rows[0]["episodes"]
    ]  # fmt: skip


def run(args: argparse.Namespace) -> int:
    import multicrane
    from multicrane.reports.seed_table import entries, markdown_table

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
        try:
            bounds = episode_bounds(rows, args.bound_time, args.sites)
        except (multicrane.ScenarioError, ValueError) as exc:
            return error(f"{args.results}: cannot bound its episodes: {exc}")
    table = markdown_table(table_entries, args.baseline, bounds)
    first = rows[0]["episodes"]
    names = sorted({e["scenario"] for e in first})
    if len(names) == 1:
        print(f"{names[0]}, {first[0]['n_cranes']} cranes, {len(first)} episodes "
              f"(reset seeds {first[0]['seed']}..{first[-1]['seed']})")  # fmt: skip
    else:
        print(f"{args.sites or 'several scenarios'}: {len(first)} episodes on {len(names)} sites")
    print(table)
    if args.out is not None:
        args.out.write_text(table + "\n")
        if bounds is not None:
            seeds = [e["seed"] for e in first]
            episodes = [[e["scenario"], e["seed"]] for e in first]
            args.out.with_suffix(".bounds.json").write_text(
                json.dumps({"seeds": seeds, "episodes": episodes, "bounds": bounds}) + "\n"
            )
    return 0
