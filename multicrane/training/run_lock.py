"""A run directory's lock: one process trains a run at a time, and the lock names its owner.

``run.lock`` in the run directory holds the owner's pid, host and start time (JSON) and is
held with ``fcntl.flock`` for as long as the run trains. The kernel drops a flock when its
process dies, however it dies (SIGKILL included), so a dead owner's lock is simply taken
over, and the file's old content names who held it (said in a message). A live owner's
lock is refused with :class:`RunLockedError` naming the owner. On a shared filesystem the
flock is as good as the filesystem's locking (NFS v4 locks work across hosts).
"""

from __future__ import annotations

import datetime
import fcntl
import json
import os
import socket
from collections.abc import Callable
from pathlib import Path

LOCK = "run.lock"


class RunLockedError(RuntimeError):
    """The run directory is in use by another live process; the message names it."""


class RunLock:
    """``with RunLock(run_dir, log):`` holds the run's lock for the block."""

    def __init__(self, run_dir: str | Path, log: Callable[[str], None] = print):
        self.path = Path(run_dir) / LOCK
        self.log = log
        self._fd: int | None = None

    def __enter__(self) -> RunLock:
        self.acquire()
        return self

    def __exit__(self, *exc) -> None:
        self.release()

    def acquire(self) -> None:
        """Take the lock or raise RunLockedError; a dead owner's lock is taken over."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                owner = _read(fd)
                os.close(fd)
                raise RunLockedError(
                    f"{self.path.parent} is in use by {describe(owner)}: it trains this run "
                    "now; wait for it to finish or stop it"
                ) from None
            # A releasing owner may have unlinked the file between our open and flock.
            try:
                same = os.stat(self.path).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        previous = _read(fd)
        if previous:
            self.log(f"{self.path}: took over the lock of {describe(previous)}, which has ended")
        mine = {
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "started": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        }
        os.ftruncate(fd, 0)
        os.pwrite(fd, (json.dumps(mine) + "\n").encode(), 0)
        self._fd = fd

    def release(self) -> None:
        """Remove the file and drop the lock (removing first: nobody takes a stale file)."""
        if self._fd is None:
            return
        try:
            self.path.unlink(missing_ok=True)
        finally:
            os.close(self._fd)
            self._fd = None


def owner(run_dir: str | Path) -> dict | None:
    """Who holds the run's lock now (pid, host, started), or None when nobody does."""
    path = Path(run_dir) / LOCK
    try:
        fd = os.open(path, os.O_RDONLY)
    except FileNotFoundError:
        return None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:
            return _read(fd) or {"pid": "?", "host": "?", "started": "?"}
        return None
    finally:
        os.close(fd)


def describe(info: dict | None) -> str:
    if not info:
        return "another process (owner unknown)"
    return (
        f"process {info.get('pid', '?')} on {info.get('host', '?')} "
        f"(started {info.get('started', '?')})"
    )


def _read(fd: int) -> dict | None:
    try:
        data = json.loads(os.pread(fd, 4096, 0).decode() or "null")
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None
