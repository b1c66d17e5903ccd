"""``multicrane check``: validate a scenario file strictly and summarise it."""

from __future__ import annotations

import argparse
from collections import Counter

from multicrane.cli.common import formatter

DESCRIPTION = """Validate a scenario (a .toml file or a shipped name): load it with the strict
reader, build its environment and draw one start. Prints a summary; on the first problem
prints it and exits with status 1.

    multicrane check scenarios/hall-4c.toml
    multicrane check my-site.toml --cranes 3
"""


def register(sub) -> None:
    p = sub.add_parser("check", help="validate a scenario file", description=DESCRIPTION,
                       **formatter())  # fmt: skip
    p.add_argument("scenario", nargs="+", help="scenario file(s) or shipped name(s)")
    p.add_argument("--cranes", type=int, default=None, help="also try this many cranes")
    p.add_argument("--seed", type=int, default=0, help="seed of the start drawn")
    p.set_defaults(func=run)


def summary(scenario) -> str:
    """A few lines about a loaded scenario."""
    kinds = Counter(c.kind.name.lower() for c in scenario.components)
    prebuilt = sum(c.prebuilt for c in scenario.components)
    x, y, z = scenario.size
    parts = ", ".join(f"{n} {k}{'s' if n != 1 else ''}" for k, n in sorted(kinds.items()))
    lines = [
        f"{scenario.name}: ok ({scenario.source})",
        f"  site {x}x{y}x{z}, {len(scenario.foundations)} foundation(s), "
        f"{len(scenario.obstacles)} obstacle(s)",
        f"  {scenario.n_components} components ({parts}; {prebuilt} pre-built), "
        f"{scenario.cranes} crane(s), step limit {scenario.step_limit}",
        f"  start: {'drawn at reset' if scenario.random_start else 'fixed'}; targets "
        f"{'interchangeable' if scenario.interchangeable_targets else 'one per component'}",
        f"  sha256 {scenario.sha256}",
    ]
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    import multicrane

    status = 0
    for name in args.scenario:
        try:
            scenario = multicrane.load_scenario(name)
            env = multicrane.parallel_env(scenario, n_cranes=args.cranes)
            env.reset(seed=args.seed)
        except (multicrane.ScenarioError, OSError) as exc:
            print(exc if name in str(exc) else f"{name}: {exc}")
            status = 1
            continue
        print(summary(scenario))
    return status
