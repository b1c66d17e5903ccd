"""The in-process backend: runs a sweep's jobs one after the other in this process
(debugging, tests)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

from multicrane.benchmark.jobs import Job, Outcome, Report, execute_run


class SerialBackend:
    """Runs the jobs one after the other in this process (debugging, tests). A Ctrl-C
    stops the current run with a checkpoint (the trainer's handler) and ends the sweep."""

    name = "serial"
    returns_results = False

    def __init__(self, runner: Callable[[Job], Outcome] = execute_run):
        self.runner = runner
        self.workers = 1

    def run(self, jobs: Sequence[Job], report: Report) -> bool:
        """True when interrupted."""
        for job in jobs:
            try:
                outcome = self.runner(job)
            except KeyboardInterrupt:
                outcome = Outcome(job.name, "stopped", detail="interrupted")
            report(outcome)
            if outcome.status == "stopped":
                return True
        return False
