"""The ``multicrane`` command: one parser, one subcommand per module of this package.

    multicrane --help
    multicrane plan hall-4c --cranes 4 --policy prioritized
    multicrane check my-site.toml

Each subcommand module exposes ``register(subparsers)``, which adds its parser and sets
``func(args) -> int``. Modules import heavy packages (torch, stable-baselines3, rerun,
matplotlib, ray) only when their command runs; a missing one is reported with the extra that
installs it. This package is the top floor of the project: the only part of ``multicrane``
that may import ``policies``.

May import: every room, and ``policies``.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from multicrane.cli.common import missing_extra, needs_extra

# The subcommands, in the order ``--help`` lists them (modules of this package).
COMMANDS = (
    "plan",
    "evaluate",
    "train",
    "replay",
    "gantt",
    "check",
    "generate",
    "import_ifc",
    "export_4d",
    "bound",
    "suite",
    "bench",
    "marl_bench",
    "seed_table",
    "benchmark",
    "paper_table",
    "compare_planners",
    "uncertainty",
    "demo",
)


def build_parser() -> argparse.ArgumentParser:
    """The parser of the whole command, with every subcommand registered."""
    from multicrane import __version__

    p = argparse.ArgumentParser(
        prog="multicrane",
        description="Multi-crane assembly planning: run, evaluate, train and replay policies "
        "on construction-site scenarios. `multicrane COMMAND --help` for each command.",
    )
    p.add_argument("--version", action="version", version=f"multicrane {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in COMMANDS:
        try:
            module = importlib.import_module(f"multicrane.cli.{name}")
        except ModuleNotFoundError as exc:
            if exc.name == f"multicrane.cli.{name}":
                continue  # a subcommand not in this build
            raise
        module.register(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    """Run the command line ``argv`` (default: this process's arguments); the exit status."""
    argv = sys.argv[1:] if argv is None else list(argv)
    args = build_parser().parse_args(argv)
    args.argv = argv
    try:
        return int(args.func(args) or 0)
    except ImportError as exc:
        extra = missing_extra(exc)
        if extra is None:
            raise
        return needs_extra(args.command, extra)
