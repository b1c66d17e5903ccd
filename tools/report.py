"""Shared pieces of the programs that write results pages: how they were run, and where."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path

from multicrane.reports.provenance import machine  # noqa: F401  (re-exported)

ROOT = Path(__file__).resolve().parent.parent


def add_environment_args(p) -> None:
    """``--paper CONFIG`` or ``--scenario NAME`` (one of them), ``--cranes``, ``--auto``."""
    where = p.add_mutually_exclusive_group(required=True)
    where.add_argument("--paper", metavar="CONFIG", help="single-agent benchmark: E1S1 .. E4S4")
    where.add_argument("--scenario", help="multi-agent: shipped scenario name or .toml path")
    p.add_argument("--cranes", type=int, default=None, help="cranes (default: scenario's)")
    p.add_argument("--auto", action="store_true", help="multi-agent automatic mode")


def command_line(script: str, argv: list[str] | None) -> str:
    """The command that produced a page, as typed from the repository root."""
    python = Path(sys.executable)
    try:
        python = python.relative_to(ROOT)
    except ValueError:
        python = Path(python.name)
    script_path = Path(script).resolve().relative_to(ROOT)
    args = sys.argv[1:] if argv is None else argv
    return shlex.join([str(python), str(script_path), *args])
