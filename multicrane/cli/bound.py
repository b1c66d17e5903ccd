"""``multicrane bound``: a proven lower bound on the makespan (CP-SAT), beside a planner's."""

from __future__ import annotations

import argparse
import json

from multicrane.cli.common import error, formatter

DESCRIPTION = """A proven lower bound on the makespan (joint steps until the last component is
assembled, claiming mode) of the episode reset(seed=--seed) starts, from a scheduling
relaxation solved with OR-Tools CP-SAT (see docs/bound.md): cranes as machines (with reach),
one task per component (claim + shortest path through the static site + assembly), supports
as precedence, interchangeable targets as options.

    multicrane bound hall-4c --cranes 4
    multicrane bound hall-4c frame2-3c --cranes 1 2 3 4 --planner prioritized
    multicrane bound e3s2 --cranes 2 --time-limit 5 --json

Status "optimal": the solver proved the relaxation's optimum (the bound is that optimum);
"feasible"/"unknown": it stopped at the time limit and the bound is its best proven one.
--planner also plays that planner on the same seed and prints its makespan and the gap
(makespan - bound) / bound; --markdown prints the table as markdown. A setting that cannot
be bounded (a bad crane count, a component no crane can carry) is reported in one line on
stderr and the others still run; the exit status is then 1.
"""


def register(sub) -> None:
    p = sub.add_parser("bound", help="a proven lower bound on the makespan (CP-SAT)",
                       description=DESCRIPTION, **formatter())  # fmt: skip
    p.add_argument("scenario", nargs="+", help="shipped scenario name(s) or .toml path(s)")
    p.add_argument("--cranes", nargs="+", type=int, default=[None],
                   help="crane count(s) (default: the scenario's)")  # fmt: skip
    p.add_argument("--seed", type=int, default=0, help="the episode's reset seed")
    p.add_argument("--time-limit", type=float, default=60.0, help="seconds per solve")
    p.add_argument("--workers", type=int, default=2, help="CP-SAT worker threads")
    p.add_argument("--planner", default=None, help="also run this planner (e.g. prioritized)")
    out = p.add_mutually_exclusive_group()
    out.add_argument("--json", action="store_true", help="one JSON object per line")
    out.add_argument("--markdown", action="store_true", help="a markdown table")
    p.set_defaults(func=run)


def describe(row) -> str:
    """One line about one bound (and the planner's makespan, if one ran)."""
    b = row.bound
    proven = (
        "the relaxation's optimum, proven"
        if b.optimal
        else f"{b.status}: best proven bound at the time limit"
    )
    text = (
        f"{b.scenario}, {b.n_cranes} crane(s), seed {b.seed}: makespan >= {b.value} "
        f"({proven}); {b.n_tasks} tasks, {b.wall_s:.2f} s"
    )
    if row.policy is not None:
        made = "did not finish" if row.makespan is None else f"makespan {row.makespan}"
        gap = "" if row.gap is None else f", gap {row.gap:.1%}"
        text += f"; {row.policy} {made}{gap}"
    return text


def run(args: argparse.Namespace) -> int:
    import multicrane
    from multicrane.reports.bounds import bound_row, markdown_table

    if not args.time_limit > 0:
        return error(f"--time-limit must be positive, got {args.time_limit}", 1)
    if args.workers < 1:
        return error(f"--workers must be at least 1, got {args.workers}", 1)
    make_policy = None
    if args.planner is not None:
        import policies

        try:
            policies.factory(args.planner)
        except policies.PolicyError as exc:
            return error(exc, 1)

        def make_policy(env, seed):
            return policies.make(args.planner, env, seed=seed)

    try:
        scenarios = [multicrane.load_scenario(name) for name in args.scenario]
    except (multicrane.ScenarioError, OSError) as exc:
        return error(exc, 1)
    rows, status = [], 0
    for scenario in scenarios:
        for n in args.cranes:
            try:
                row = bound_row(scenario, n, args.seed, make_policy, args.planner,
                                args.time_limit, args.workers)  # fmt: skip
            except (multicrane.ScenarioError, ValueError, OSError) as exc:
                # e.g. a tower-crane site some of whose components these cranes cannot carry:
                # say so in one line and go on with the other settings.
                status = error(exc, 1)
                continue
            rows.append(row)
            if args.json:
                print(json.dumps(row.as_dict()), flush=True)
            elif not args.markdown:
                print(describe(row), flush=True)
    if args.markdown and rows:
        print(markdown_table(rows))
    return status
