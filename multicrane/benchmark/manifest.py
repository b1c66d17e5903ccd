"""A sweep directory's own bookkeeping: ``sweep.json`` (what the sweep is and the sessions
that ran it: command, machine, dates) and the ``.lock`` that lets one driver run it at a time.
"""

from __future__ import annotations

import datetime
import fcntl
import os
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from multicrane.benchmark.choices import SweepError
from multicrane.benchmark.estimate import format_duration
from multicrane.benchmark.profiles import Sweep
from multicrane.benchmark.runstate import read_json
from multicrane.files import write_json_atomic

MANIFEST = "sweep.json"
LOCK = ".lock"


def read_manifest(out: Path) -> dict:
    """``<out>/sweep.json``, or {} when it is missing or unreadable."""
    data, problem = read_json(Path(out) / MANIFEST)
    return data if not problem and isinstance(data, dict) else {}


def record_session(sweep: Sweep, session: dict[str, Any]) -> None:
    """Add one session (command, backend, machine, start and end) to ``sweep.json``."""
    sweep.out.mkdir(parents=True, exist_ok=True)
    manifest = read_manifest(sweep.out)
    sessions = manifest.get("sessions", []) if isinstance(manifest.get("sessions"), list) else []
    manifest = {**sweep.to_dict(), "sessions": [*sessions, session]}
    write_json_atomic(sweep.out / MANIFEST, manifest, indent=2)


def session_labels(sweep: Sweep) -> dict[str, str]:
    """The report's labels from the recorded sessions: the last run command, its machine,
    the dates and the wall time of all sessions together."""
    sessions = read_manifest(sweep.out).get("sessions") or []
    sessions = [s for s in sessions if isinstance(s, dict)]
    labels: dict[str, str] = {}
    if not sessions:
        return labels
    last = sessions[-1]
    command = f"`{last.get('command', '?')}`"
    if len(sessions) > 1:
        command += f" ({len(sessions)} sessions, this was the last)"
    labels["run_command"] = command
    labels["machine"] = str(last.get("machine", ""))
    first, end = sessions[0].get("started", ""), last.get("finished", "")
    wall = 0.0
    for s in sessions:
        try:
            a = datetime.datetime.fromisoformat(s["started"])
            b = datetime.datetime.fromisoformat(s["finished"])
            wall += (b - a).total_seconds()
        except (KeyError, TypeError, ValueError):
            pass
    labels["date"] = f"runs {first} .. {end}"
    labels["wall"] = (
        f"{format_duration(wall)} wall time with {last.get('workers', '?')} "
        f"{last.get('backend', '')} workers"
    )
    return labels


@contextmanager
def sweep_lock(out: Path):
    """Hold ``<out>/.lock`` while a sweep runs: two drivers training the same run
    directories would overwrite each other's checkpoints."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / LOCK, "a+") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            f.seek(0)
            holder = f.read().strip() or "another process"
            raise SweepError(
                f"{out} is being run by {holder}: wait for it, or stop it (Ctrl-C) first"
            ) from None
        f.seek(0)
        f.truncate()
        f.write(f"pid {os.getpid()}\n")
        f.flush()
        try:
            yield
        finally:
            f.truncate(0)
            fcntl.flock(f, fcntl.LOCK_UN)
