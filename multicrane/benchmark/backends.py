"""Where the runs of a sweep execute: this process, a pool of local processes, or Ray.

Every backend runs ``execute_run`` (one ``multicrane.training.train`` call in the run's
directory) on each ``Task`` and hands each ``Outcome`` to a callback as it arrives. A run
that raises is reported as failed, with its name and error, and the others go on.

Local processes (the default): ``workers`` processes started with "spawn" (no state shared
with the driver; each imports torch once and uses one torch thread), each running one
training at a time; the driver hands out runs longest first. The workers sit in their own
process group, so a Ctrl-C reaches only the driver, which then:

1. hands out no more runs and sends SIGTERM to busy workers (again every second, to catch
   a worker that had not yet installed the trainer's handler): each run stops at its next
   update boundary with a checkpoint, exactly as ``tools/train.py`` does on Ctrl-C;
2. on a second Ctrl-C sends SIGINT: runs stop at once, back to their last checkpoint;
3. on a third, kills the workers.

A worker that dies (out of memory, a crash in native code) fails its run; a new worker
takes its place.

Ray (``pip install 'multicrane[ray]'``): each run is a task with ``num_cpus=1``. The task
trains in the run's directory when the worker can create it (the same machine, or a shared
filesystem) and otherwise in a temporary directory on its node; either way it returns the
result, which the driver writes as the run's ``result.json`` if it is not there yet. So
results always land in the driver's output directory, but checkpoints of unfinished runs
stay on the node that wrote them: for resume across interruptions on a cluster, put the
output directory on a shared filesystem. Ctrl-C cancels the tasks: Ray delivers the
cancellation to a running task as SIGINT, so its run stops at the next update with a
checkpoint, as locally; a second Ctrl-C force-cancels (the worker is killed and the run goes
back to its last checkpoint).
"""

from __future__ import annotations

import contextlib
import hashlib
import multiprocessing
import os
import signal
import tempfile
import threading
import time
import traceback
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from multiprocessing.connection import wait
from pathlib import Path
from typing import Any

from multicrane.benchmark.sweep import ERROR


@dataclass(frozen=True)
class Task:
    """One run to execute: its name, directory and ``TrainConfig`` keyword arguments."""

    name: str
    run_dir: str
    train: dict[str, Any]
    return_result: bool = False  # send the whole result dict back (Ray)


@dataclass(frozen=True)
class Outcome:
    """What became of a task: ``done``, ``stopped`` (interrupted, resumable) or ``failed``."""

    name: str
    status: str
    seconds: float = 0.0
    detail: str = ""
    error: str = ""
    final: dict[str, Any] | None = None
    result: dict[str, Any] | None = None


Report = Callable[[Outcome], None]


def execute_run(task: Task) -> Outcome:
    """Train one run (resuming what its directory holds); never raises for a failed run."""
    start = time.perf_counter()
    run_dir = Path(task.run_dir)
    if task.return_result:
        run_dir = _writable_run_dir(task)

    def log(message: str) -> None:
        print(f"[{task.name}] {message}", flush=True)

    try:
        from multicrane.training import TrainConfig, train

        result = train(TrainConfig(**task.train), run_dir, progress_bar=False, log=log)
    except KeyboardInterrupt:
        return Outcome(
            task.name,
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
            task.name,
            "failed",
            time.perf_counter() - start,
            error=f"{type(exc).__name__}: {exc}",
            detail=text,
        )
    seconds = time.perf_counter() - start
    if result is None:
        return Outcome(task.name, "stopped", seconds, detail="stopped with a checkpoint")
    return Outcome(
        task.name,
        "done",
        seconds,
        final=result.get("final"),
        result=result if task.return_result else None,
    )


def _writable_run_dir(task: Task) -> Path:
    """The task's directory, or a directory on this node's temporary filesystem when the
    driver's path cannot be created here (a Ray worker without the shared filesystem)."""
    run_dir = Path(task.run_dir)
    try:
        run_dir.mkdir(parents=True, exist_ok=True)
        probe = run_dir / f".write-test-{os.getpid()}"
        probe.write_text("")
        probe.unlink()
        return run_dir
    except OSError:
        key = hashlib.sha1(task.run_dir.encode()).hexdigest()[:12]  # one per driver path
        local = Path(tempfile.gettempdir()) / "multicrane-bench" / key
        local.mkdir(parents=True, exist_ok=True)
        return local


# -- this process --------------------------------------------------------------------------------


class SerialBackend:
    """Runs the tasks one after the other in this process (debugging, tests). A Ctrl-C
    stops the current run with a checkpoint (the trainer's handler) and ends the sweep."""

    name = "serial"
    returns_results = False

    def __init__(self, runner: Callable[[Task], Outcome] = execute_run):
        self.runner = runner
        self.workers = 1

    def run(self, tasks: Sequence[Task], report: Report) -> bool:
        """True when interrupted."""
        for task in tasks:
            try:
                outcome = self.runner(task)
            except KeyboardInterrupt:
                outcome = Outcome(task.name, "stopped", detail="interrupted")
            report(outcome)
            if outcome.status == "stopped":
                return True
        return False


# -- local processes -----------------------------------------------------------------------------


def _serve(conn, runner: Callable[[Task], Outcome]) -> None:
    """A worker: run the tasks the driver sends until it sends None."""
    os.setpgrp()  # Ctrl-C in the terminal goes to the driver only; it forwards signals
    signal.signal(signal.SIGTERM, signal.SIG_IGN)  # the trainer's handler takes it in a run
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    try:
        conn.send(READY)  # from now on, signals from the driver are safe
    except OSError:
        return
    while True:
        try:
            task = conn.recv()
        except (EOFError, OSError, KeyboardInterrupt):
            return
        if task is None:
            return
        try:
            outcome = runner(task)
        except KeyboardInterrupt:
            outcome = Outcome(task.name, "stopped", detail="stopped at once")
        except BaseException as exc:  # report it; the driver decides what comes next
            outcome = Outcome(task.name, "failed", error=f"{type(exc).__name__}: {exc}")
        try:
            conn.send(outcome)
        except (OSError, BrokenPipeError):
            return


READY = "ready"  # a worker's first message


@dataclass(eq=False)
class _Worker:
    process: Any
    conn: Any
    task: Task | None = None
    started: float = 0.0
    ready: bool = False  # its signal handlers are set: it may be signalled


class LocalBackend:
    """A pool of ``workers`` spawned processes; see the module doc for Ctrl-C."""

    name = "local"
    returns_results = False

    def __init__(
        self,
        workers: int | None = None,
        runner: Callable[[Task], Outcome] = execute_run,
        log: Callable[[str], None] = print,
        resend_seconds: float = 1.0,
    ):
        self.workers = max(1, workers or os.cpu_count() or 1)
        self.runner = runner
        self.log = log
        self.resend_seconds = resend_seconds
        self._interrupts = 0  # signals received
        self._handled = 0  # signals acted upon
        self._queue: deque[Task] = deque()
        self._pool: list[_Worker] = []
        self._ctx = multiprocessing.get_context("spawn")

    def _on_signal(self, signum, frame) -> None:
        self._interrupts += 1

    def run(self, tasks: Sequence[Task], report: Report) -> bool:
        """Run every task; True when interrupted (unstarted tasks are left for next time)."""
        self._queue = deque(tasks)
        self._pool = []
        self._interrupts = self._handled = 0
        if not self._queue:
            return False
        os.environ.setdefault("OMP_NUM_THREADS", "1")  # inherited by the spawned workers
        last_resend = 0.0
        previous = _install(self._on_signal)
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
            _restore(previous)
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
            target=_serve, args=(child, self.runner), name="multicrane-bench"
        )
        process.start()
        child.close()
        worker = _Worker(process, parent)
        self._pool.append(worker)
        return worker

    def _dispatch(self, w: _Worker) -> None:
        """The next task to an idle worker, or None (the worker exits) when there is none
        or the sweep is stopping."""
        if self._queue and not self._handled:
            w.task = self._queue.popleft()
            w.started = time.perf_counter()
            w.conn.send(w.task)
        else:
            w.task = None
            _send_quietly(w.conn, None)

    def _signal_busy(self, sig: int) -> None:
        """Signal the workers that run a task; only ready ones, except to kill (before its
        handlers are set, a SIGTERM would kill a worker)."""
        for w in self._pool:
            ready = w.ready or sig == signal.SIGKILL
            if w.task is not None and ready and w.process.is_alive():
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
                if w.task is None:
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
            w.task = None
            report(outcome)
            if w.process.is_alive():
                self._dispatch(w)
                return
        if w.process.is_alive():
            return
        w.process.join()
        self._pool.remove(w)
        w.conn.close()
        if w.task is None:
            return
        code = w.process.exitcode
        why = f"signal {-code}" if code is not None and code < 0 else f"exit code {code}"
        seconds = time.perf_counter() - w.started
        if self._handled:  # killed, or hit by the Ctrl-C while starting: resumable
            report(Outcome(w.task.name, "stopped", seconds, detail=f"worker ended ({why})"))
        else:
            report(
                Outcome(
                    w.task.name,
                    "failed",
                    seconds,
                    error=f"the worker process died ({why}) during this run",
                )
            )
        w.task = None
        if self._queue and not self._handled:
            self._dispatch(self._start_worker())


def _send_quietly(conn, message) -> None:
    with contextlib.suppress(OSError, BrokenPipeError):
        conn.send(message)


def _install(handler) -> dict:
    """Route SIGINT/SIGTERM to ``handler`` (only possible in the main thread)."""
    previous = {}
    if threading.current_thread() is not threading.main_thread():
        return previous
    for sig in (signal.SIGINT, signal.SIGTERM):
        previous[sig] = signal.signal(sig, handler)
    return previous


def _restore(previous: dict) -> None:
    for sig, handler in previous.items():
        signal.signal(sig, handler)


# -- Ray -----------------------------------------------------------------------------------------


def import_ray():
    """The ``ray`` module, or an error that says how to install it."""
    try:
        import ray
    except ImportError as exc:
        raise RuntimeError(
            f"the Ray backend needs ray: pip install 'multicrane[ray]' (missing: {exc.name})"
        ) from None
    return ray


class RayBackend:
    """Each run a Ray task with ``num_cpus=1``; see the module doc.

    ``address``: ``None`` starts a local Ray instance (``num_cpus`` of them, default all
    cores); ``"auto"`` joins the cluster this machine belongs to; ``"ray://host:10001"``
    connects a Ray client. When Ray is already initialised (``ray.init`` called by the
    caller), that instance is used and left running."""

    name = "ray"
    returns_results = True

    def __init__(
        self,
        address: str | None = None,
        num_cpus: int | None = None,
        runner: Callable[[Task], Outcome] = execute_run,
        log: Callable[[str], None] = print,
    ):
        self.address = address
        self.num_cpus = num_cpus
        self.runner = runner
        self.log = log
        self.workers = num_cpus or os.cpu_count() or 1
        self._interrupts = 0

    def run(self, tasks: Sequence[Task], report: Report) -> bool:
        """Run every task as a Ray task; True when interrupted."""
        if not tasks:
            return False
        ray = import_ray()
        own = not ray.is_initialized()
        if own:
            os.environ.setdefault("RAY_AUTH_MODE", "disabled")  # no token file for a local run
            options: dict[str, Any] = {
                "include_dashboard": False,
                "runtime_env": {"env_vars": {"OMP_NUM_THREADS": "1"}},
            }
            if self.address:
                ray.init(address=self.address, **options)
            else:
                ray.init(num_cpus=self.num_cpus, **options)
        self.workers = int(ray.cluster_resources().get("CPU", self.workers))
        remote = ray.remote(num_cpus=1, max_retries=0)(self.runner)
        pending = {remote.remote(task): task for task in tasks}
        self._interrupts = handled = 0
        previous = _install(self._on_signal)
        try:
            while pending:
                if self._interrupts > handled:
                    handled = self._interrupts
                    force = handled > 1
                    self.log(
                        "interrupted: cancelling the Ray tasks"
                        + (" (forced)" if force else " (Ctrl-C again: force)")
                    )
                    for ref in pending:
                        ray.cancel(ref, force=force)
                ready, _ = ray.wait(list(pending), num_returns=1, timeout=0.5)
                for ref in ready:
                    task = pending.pop(ref)
                    report(self._outcome(ray, ref, task))
        finally:
            _restore(previous)
            if own:
                ray.shutdown()
        return handled > 0

    def _on_signal(self, signum, frame) -> None:
        self._interrupts += 1

    @staticmethod
    def _outcome(ray, ref, task: Task) -> Outcome:
        try:
            return ray.get(ref)
        except ray.exceptions.TaskCancelledError:
            return Outcome(task.name, "stopped", detail="cancelled")
        except ray.exceptions.RayError as exc:
            first = str(exc).strip().splitlines()
            return Outcome(
                task.name, "failed", error=f"{type(exc).__name__}: {first[0] if first else ''}"
            )


def make_backend(
    name: str,
    workers: int | None = None,
    address: str | None = None,
    log: Callable[[str], None] = print,
):
    """A backend by name: ``local`` (default), ``ray`` or ``serial``."""
    if name == "local":
        return LocalBackend(workers, log=log)
    if name == "ray":
        return RayBackend(address=address, num_cpus=workers if not address else None, log=log)
    if name == "serial":
        return SerialBackend()
    raise ValueError(f"unknown backend {name!r}: local, ray or serial")
