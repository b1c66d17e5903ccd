"""Where and how a results page was made: the command that made it and the machine it ran on."""

from __future__ import annotations

import os
import platform
import shlex
from collections.abc import Sequence
from pathlib import Path


def command_line(words: Sequence[object], program: str = "multicrane") -> str:
    """The command as a user types it: ``program`` then ``words``, quoted for a shell."""
    return shlex.join([program, *(str(w) for w in words)])


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
