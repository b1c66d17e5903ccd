"""The local backend: a pool of spawned worker processes, each training one run at a time,
handed out longest first, with a graded Ctrl-C.

``workers`` processes started with "spawn" (no state shared with the driver; each imports
torch once and uses one torch thread). The workers sit in their own process group, so a
Ctrl-C reaches only the driver, which then:

1. hands out no more runs and sends SIGTERM to busy workers (again every second, to catch
   a worker that had not yet installed the trainer's handler): each run stops at its next
   update boundary with a checkpoint, exactly as ``multicrane train`` does on Ctrl-C;
2. on a second Ctrl-C sends SIGINT: runs stop at once, back to their last checkpoint;
3. on a third, kills the workers.

A worker that dies (out of memory, a crash in native code) fails its run; a new worker
takes its place. A worker whose driver dies (even by SIGKILL, which no handler sees) notices
within a second (a thread watching ``os.getppid()``): it stops its run as on a first Ctrl-C
(SIGTERM: a checkpoint at the next update) and exits, or is ended after ``orphan_grace``
seconds. Each run's directory lock (``multicrane.training.run_lock``) keeps a second sweep from
training a run that such a worker still holds.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from multiprocessing.connection import wait
from typing import Any

from multicrane.benchmark import interrupts
from multicrane.benchmark.jobs import Job, Outcome, Report, execute_run


def _watch_parent(parent: int, grace: float, poll: float = 0.5) -> None:
    """End this worker when its driver (``parent``) has died: SIGTERM to itself (the
    trainer stops at its next update with a checkpoint), then exit after ``grace`` s."""
    while os.getppid() == parent:
        time.sleep(poll)
    print(f"multicrane worker {os.getpid()}: the sweep driver {parent} has died; stopping")
    with contextlib.suppress(OSError):
        os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(grace)
    os._exit(3)


def _serve(conn, runner: Callable[[Job], Outcome], orphan_grace: float = 60.0) -> None:
    """A worker: run the jobs the driver sends until it sends None (or the driver dies)."""
    os.setpgrp()  # Ctrl-C in the terminal goes to the driver only; it forwards signals
    parent = os.getppid()
    threading.Thread(
        target=_watch_parent, args=(parent, orphan_grace), daemon=True, name="parent-watch"
    ).start()
    signal.signal(signal.SIGTERM, signal.SIG_IGN)  # the trainer's handler takes it in a run
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    try:
        conn.send(READY)  # from now on, signals from the driver are safe
    except OSError:
        return
    while True:
        try:
            job = conn.recv()
        except (EOFError, OSError, KeyboardInterrupt):
            return
        if job is None:
            return
        try:
            outcome = runner(job)
        except KeyboardInterrupt:
            outcome = Outcome(job.name, "stopped", detail="stopped at once")
        except BaseException as exc:  # report it; the driver decides what comes next
            outcome = Outcome(job.name, "failed", error=f"{type(exc).__name__}: {exc}")
        try:
            conn.send(outcome)
        except (OSError, BrokenPipeError):
            return


READY = "ready"  # a worker's first message


@dataclass(eq=False)
class _Worker:
    process: Any
    conn: Any
    job: Job | None = None
    started: float = 0.0
    ready: bool = False  # its signal handlers are set: it may be signalled


class LocalBackend:
    """A pool of ``workers`` spawned processes; see the module doc for Ctrl-C."""

    name = "local"
    returns_results = False

    def __init__(
        self,
        workers: int | None = None,
        runner: Callable[[Job], Outcome] = execute_run,
        log: Callable[[str], None] = print,
        resend_seconds: float = 1.0,
        orphan_grace: float = 60.0,
    ):
        self.workers = max(1, workers or os.cpu_count() or 1)
        self.runner = runner
        self.log = log
        self.resend_seconds = resend_seconds
        self.orphan_grace = orphan_grace
        self._interrupts = 0  # signals received
        self._handled = 0  # signals acted upon
        self._queue: deque[Job] = deque()
        self._pool: list[_Worker] = []
        self._ctx = multiprocessing.get_context("spawn")

    def _on_signal(self, signum, frame) -> None:
        self._interrupts += 1

    def run(self, jobs: Sequence[Job], report: Report) -> bool:
        """Run every job; True when interrupted (unstarted jobs are left for next time)."""
        self._queue = deque(jobs)
        self._pool = []
        self._interrupts = self._handled = 0
        if not self._queue:
            return False
        os.environ.setdefault("OMP_NUM_THREADS", "1")  # inherited by the spawned workers
        last_resend = 0.0
        previous = interrupts.install(self._on_signal)
        try:
            for _ in range(min(self.workers, len(self._queue))):
                self._dispatch(self._start_worker())
            while self._pool:
                if self._interrupts > self._handled:
                    self._escalate()
                now = time.perf_counter()
                if self._handled and now - last_resend >= self.resend_seconds:
                    self._signal_busy(signal.SIGTERM)
                    last_resend = now
                handles = {}
                for w in self._pool:
                    handles[w.conn] = w
                    handles[w.process.sentinel] = w
                ready = wait(list(handles), timeout=0.2)
                for w in dict.fromkeys(handles[h] for h in ready):
                    self._service(w, report)
        finally:
            interrupts.restore(previous)
            if self._pool:  # left by an error in the driver: stop the runs with checkpoints
                self._signal_busy(signal.SIGTERM)
                for w in self._pool:
                    _send_quietly(w.conn, None)
                for w in self._pool:
                    w.process.join(timeout=30)
                    if w.process.is_alive():
                        w.process.kill()
        return bool(self._handled) or bool(self._queue)

    def _start_worker(self) -> _Worker:
        parent, child = self._ctx.Pipe()
        process = self._ctx.Process(
            target=_serve, args=(child, self.runner, self.orphan_grace), name="multicrane-bench"
        )
        process.start()
        child.close()
        worker = _Worker(process, parent)
        self._pool.append(worker)
        return worker

    def _dispatch(self, w: _Worker) -> None:
        """The next job to an idle worker, or None (the worker exits) when there is none
        or the sweep is stopping."""
        if self._queue and not self._handled:
            w.job = self._queue.popleft()
            w.started = time.perf_counter()
            w.conn.send(w.job)
        else:
            w.job = None
            _send_quietly(w.conn, None)

    def _signal_busy(self, sig: int) -> None:
        """Signal the workers that run a job; only ready ones, except to kill (before its
        handlers are set, a SIGTERM would kill a worker)."""
        for w in self._pool:
            ready = w.ready or sig == signal.SIGKILL
            if w.job is not None and ready and w.process.is_alive():
                with contextlib.suppress(ProcessLookupError):
                    os.kill(w.process.pid, sig)

    def _escalate(self) -> None:
        self._handled = self._interrupts
        if self._handled == 1:
            self.log(
                "interrupted: the running runs stop at their next update with a checkpoint "
                "(Ctrl-C again: stop at once, back to the last checkpoint)"
            )
            for w in self._pool:
                if w.job is None:
                    _send_quietly(w.conn, None)
        elif self._handled == 2:
            self.log("stopping at once")
            self._signal_busy(signal.SIGINT)
        else:
            self.log("killing the workers")
            self._signal_busy(signal.SIGKILL)

    def _service(self, w: _Worker, report: Report) -> None:
        """Take a worker's outcome, or notice that it died."""
        outcome = None
        try:
            while w.conn.poll():
                outcome = w.conn.recv()
                if outcome != READY:
                    break
                w.ready, outcome = True, None
        except (EOFError, OSError):
            outcome = None
        if outcome is not None:
            w.job = None
            report(outcome)
            if w.process.is_alive():
                self._dispatch(w)
                return
        if w.process.is_alive():
            return
        w.process.join()
        self._pool.remove(w)
        w.conn.close()
        if w.job is None:
            return
        code = w.process.exitcode
        why = f"signal {-code}" if code is not None and code < 0 else f"exit code {code}"
        seconds = time.perf_counter() - w.started
        if self._handled:  # killed, or hit by the Ctrl-C while starting: resumable
            report(Outcome(w.job.name, "stopped", seconds, detail=f"worker ended ({why})"))
        else:
            report(
                Outcome(
                    w.job.name,
                    "failed",
                    seconds,
                    error=f"the worker process died ({why}) during this run",
                )
            )
        w.job = None
        if self._queue and not self._handled:
            self._dispatch(self._start_worker())


def _send_quietly(conn, message) -> None:
    with contextlib.suppress(OSError, BrokenPipeError):
        conn.send(message)
