"""The Ray backend (``pip install 'multicrane[ray]'``): each run a Ray task with
``num_cpus=1``, on a local Ray instance or a cluster.

The job trains in the run's directory when the worker can create it (the same machine, or
a shared filesystem) and otherwise in a temporary directory on its node; either way it
returns the result, which the driver writes as the run's ``result.json`` if it is not there
yet. So results always land in the driver's output directory, but checkpoints of unfinished
runs stay on the node that wrote them: for resume across interruptions on a cluster, put the
output directory on a shared filesystem. Ctrl-C cancels the jobs: Ray delivers the
cancellation to a running job as SIGINT, so its run stops at the next update with a
checkpoint, as locally; a second Ctrl-C force-cancels (the worker is killed and the run goes
back to its last checkpoint). ray is imported only when a sweep runs.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from typing import Any

from multicrane.benchmark import interrupts
from multicrane.benchmark.jobs import Job, Outcome, Report, execute_run


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
        runner: Callable[[Job], Outcome] = execute_run,
        log: Callable[[str], None] = print,
    ):
        self.address = address
        self.num_cpus = num_cpus
        self.runner = runner
        self.log = log
        self.workers = num_cpus or os.cpu_count() or 1
        self._interrupts = 0

    def run(self, jobs: Sequence[Job], report: Report) -> bool:
        """Run every job as a Ray task; True when interrupted."""
        if not jobs:
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
                # "local": start our own Ray, never join one already running here.
                ray.init(address="local", num_cpus=self.num_cpus, **options)
        self.workers = int(ray.cluster_resources().get("CPU", self.workers))
        remote = ray.remote(num_cpus=1, max_retries=0)(self.runner)
        pending = {remote.remote(job): job for job in jobs}
        self._interrupts = handled = 0
        previous = interrupts.install(self._on_signal)
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
                    job = pending.pop(ref)
                    report(self._outcome(ray, ref, job))
        finally:
            interrupts.restore(previous)
            if own:
                ray.shutdown()
        return handled > 0

    def _on_signal(self, signum, frame) -> None:
        self._interrupts += 1

    @staticmethod
    def _outcome(ray, ref, job: Job) -> Outcome:
        try:
            return ray.get(ref)
        except ray.exceptions.TaskCancelledError:
            return Outcome(job.name, "stopped", detail="cancelled")
        except ray.exceptions.RayError as exc:
            first = str(exc).strip().splitlines()
            return Outcome(
                job.name, "failed", error=f"{type(exc).__name__}: {first[0] if first else ''}"
            )
