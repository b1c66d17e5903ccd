"""The in-process backend: runs a sweep's tasks one after the other in this process
(debugging, tests)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

from multicrane.benchmark.jobs import Outcome, Report, Task, execute_run


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
