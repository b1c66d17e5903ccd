"""How and where a results page was made: the command that produced it and the machine."""

from __future__ import annotations

import os
import platform
import shlex
import sys
from pathlib import Path


def command_line(argv: list[str] | None = None, program: str = "multicrane") -> str:
    """The command that produced a page: ``program`` followed by its arguments (``argv``, or
    this process's own arguments when None)."""
    args = sys.argv[1:] if argv is None else list(argv)
    return shlex.join([program, *args])


def machine() -> str:
    """Cores, CPU model, system, Python, and the load when the run ended."""
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    load = ""
    if hasattr(os, "getloadavg"):
        load = f", load average {os.getloadavg()[0]:.1f} at the end of the run (shared machine)"
    return (
        f"{os.cpu_count()}-core {model} CPU, {platform.system()}, "
        f"{platform.python_implementation()} {platform.python_version()}{load}"
    )
