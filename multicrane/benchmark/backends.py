"""Where the runs of a sweep execute, chosen by name: ``local`` (a pool of worker
processes, the default), ``ray`` (Ray tasks, local or on a cluster) or ``serial`` (this
process).

Every backend has ``name``, ``workers``, ``returns_results`` (whether outcomes carry the
whole result for the driver to write) and ``run(jobs, report) -> interrupted``: it runs
``execute_run`` on each ``Job`` and hands each ``Outcome`` to ``report`` as it arrives. A
run that raises is reported as failed, with its name and error, and the others go on.
"""

from __future__ import annotations

from collections.abc import Callable

from multicrane.benchmark.local import LocalBackend
from multicrane.benchmark.ray_backend import RayBackend
from multicrane.benchmark.serial import SerialBackend


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
