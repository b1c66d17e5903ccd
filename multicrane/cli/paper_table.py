"""``multicrane paper-table``: reference returns of the paper's 16 configurations beside Table I."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from multicrane.cli import progress
from multicrane.cli.common import formatter

DESCRIPTION = """Reference returns for the 16 configurations of the paper's benchmark, beside
the best entry of its Table I.

    multicrane paper-table                          # 100 episodes x 16 configurations
    multicrane paper-table --configs E1S1 E4S2 --episodes 20
    multicrane paper-table --markdown --output docs/paper-results.md

For each configuration it plays the episodes reset(seed=first + i) starts with three
policies: optimal (the exact best return of each episode), greedy (shortest path to the
nearest free target the current component can fill) and random (uniform over the six
actions, its own generator seeded per episode with (seed, 1)). It prints the mean return
± standard error, success rate and mean steps of each, the best Table I entry (with its
algorithm) and the gap between that entry and the optimum. --markdown prints a whole page.
"""


def register(sub) -> None:
    from multicrane.envs.paper_env import PAPER_CONFIGS

    p = sub.add_parser("paper-table", help="reference returns of the 16 paper configurations",
                       description=DESCRIPTION, **formatter())  # fmt: skip
    p.add_argument("--episodes", type=int, default=100, help="episodes per configuration")
    p.add_argument("--configs", nargs="+", default=list(PAPER_CONFIGS), type=str.upper,
                   choices=PAPER_CONFIGS, metavar="CONFIG",
                   help="configurations to run (default: all 16, E1S1 .. E4S4)")  # fmt: skip
    p.add_argument("--seed", type=int, default=0, help="first episode seed")
    p.add_argument("--markdown", action="store_true", help="print a markdown page")
    p.add_argument("--output", type=Path, default=None, help="write to this file")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import policies
    from multicrane.cli.common import error
    from multicrane.files import write_atomic
    from multicrane.reports.paper_page import markdown_page
    from multicrane.reports.paper_table import POLICIES, evaluate_config, text_table
    from multicrane.reports.provenance import command_line

    if args.episodes < 1:
        return error("--episodes must be at least 1")
    seeds = range(args.seed, args.seed + args.episodes)
    makers = {name: policies.factory(name, paper=True) for name in POLICIES}
    start = time.perf_counter()
    rows = []
    total = len(args.configs) * len(POLICIES) * len(seeds)
    with progress.bar(total, "paper-table") as advance:
        for config in args.configs:
            rows.append(evaluate_config(config, makers, seeds, advance))
            if not progress.enabled():
                print(f"{config} done ({time.perf_counter() - start:.1f} s)", file=sys.stderr)
    wall = time.perf_counter() - start
    if args.markdown:
        text = markdown_page(rows, seeds, wall, command_line(args.argv))
    else:
        text = text_table(rows, seeds, wall)
    if args.output is not None:
        write_atomic(args.output, text)
        print(f"wrote {args.output}", file=sys.stderr)
    else:
        print(text, end="")
    return 0
