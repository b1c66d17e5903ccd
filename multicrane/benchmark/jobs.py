"""One run as a unit of work: a ``Job`` goes to a backend, ``execute_run`` trains it (one
``multicrane.training.train`` call in the run's directory) and an ``Outcome`` comes back.

``execute_run`` never raises for a failed run: the error goes into the run's ``error.txt``
and the outcome, and the sweep goes on. torch is imported only when a run starts.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from multicrane.benchmark.runstate import ERROR
from multicrane.training.run_lock import RunLockedError


@dataclass(frozen=True)
class Job:
    """One run to execute: its name, directory and ``TrainConfig`` keyword arguments."""

    name: str
    run_dir: str
    train: dict[str, Any]
    return_result: bool = False  # send the whole result dict back (Ray)


@dataclass(frozen=True)
class Outcome:
    """What became of a job: ``done``, ``stopped`` (interrupted, resumable) or ``failed``."""

    name: str
    status: str
    seconds: float = 0.0
    detail: str = ""
    error: str = ""
    final: dict[str, Any] | None = None
    result: dict[str, Any] | None = None


Report = Callable[[Outcome], None]


def execute_run(job: Job) -> Outcome:
    """Train one run (resuming what its directory holds); never raises for a failed run."""
    start = time.perf_counter()
    run_dir = Path(job.run_dir)
    if job.return_result:
        run_dir = _writable_run_dir(job)

    def log(message: str) -> None:
        print(f"[{job.name}] {message}", flush=True)

    try:
        from multicrane.training import TrainConfig, train

        result = train(TrainConfig(**job.train), run_dir, progress_bar=False, log=log)
    except RunLockedError as exc:  # another live process trains it: leave its files alone
        return Outcome(job.name, "failed", time.perf_counter() - start, error=str(exc))
    except KeyboardInterrupt:
        return Outcome(
            job.name,
            "stopped",
            time.perf_counter() - start,
            detail="stopped at once: resumes from its last checkpoint, if any",
        )
    except Exception as exc:  # one failed run must not end the sweep
        text = traceback.format_exc()
        try:
            run_dir.mkdir(parents=True, exist_ok=True)
            (run_dir / ERROR).write_text(text)
        except OSError:
            pass
        return Outcome(
            job.name,
            "failed",
            time.perf_counter() - start,
            error=f"{type(exc).__name__}: {exc}",
            detail=text,
        )
    seconds = time.perf_counter() - start
    if result is None:
        return Outcome(job.name, "stopped", seconds, detail="stopped with a checkpoint")
    return Outcome(
        job.name,
        "done",
        seconds,
        final=result.get("final"),
        result=result if job.return_result else None,
    )


def _writable_run_dir(job: Job) -> Path:
    """The job's directory, or a directory on this node's temporary filesystem when the
    driver's path cannot be created here (a Ray worker without the shared filesystem)."""
    run_dir = Path(job.run_dir)
    try:
        run_dir.mkdir(parents=True, exist_ok=True)
        probe = run_dir / f".write-test-{os.getpid()}"
        probe.write_text("")
        probe.unlink()
        return run_dir
    except OSError:
        key = hashlib.sha1(job.run_dir.encode()).hexdigest()[:12]  # one per driver path
        local = Path(tempfile.gettempdir()) / "multicrane-bench" / key
        local.mkdir(parents=True, exist_ok=True)
        return local
