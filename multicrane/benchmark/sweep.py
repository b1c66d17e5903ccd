"""Running a sweep: skip what is done, repair and resume what was started, start the rest
longest first on a backend, and report each run as it ends.

Nothing here imports torch: the training happens in the backend's workers. The run
directories are the sweep's state (``multicrane.benchmark.runstate``), so running the same
sweep again picks up where the last session stopped.
"""

from __future__ import annotations

import datetime
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

from multicrane.benchmark.choices import SweepError
from multicrane.benchmark.estimate import estimate_wall, format_duration, longest_first
from multicrane.benchmark.jobs import Job
from multicrane.benchmark.manifest import sweep_lock
from multicrane.benchmark.profiles import Sweep
from multicrane.benchmark.runstate import (
    DONE,
    ERROR,
    conflict_message,
    conflicts,
    inspect_run,
    prepare_run,
    store_result,
)


@dataclass
class SweepRun:
    """What one ``run_sweep`` call did."""

    total: int  # runs in the sweep
    done_before: int  # already finished: skipped
    outcomes: list  # Outcome of each run handed to the backend, in the order they ended
    interrupted: bool
    seconds: float

    def count(self, status: str) -> int:
        return sum(o.status == status for o in self.outcomes)

    @property
    def failed(self) -> list:
        return [o for o in self.outcomes if o.status == "failed"]

    @property
    def complete(self) -> bool:
        return self.done_before + self.count("done") == self.total


def validate_configs(sweep: Sweep) -> None:
    """Build one ``TrainConfig`` per configuration and algorithm, so that a bad setting is
    reported before any worker starts (skipped when the training stack is not installed
    here, e.g. a Ray client)."""
    try:
        from multicrane.training import ConfigError, TrainConfig
    except ImportError:
        return
    for config in sweep.configs:
        for algo in sweep.algos:
            try:
                TrainConfig(**sweep.train_kwargs(config, algo, sweep.seeds[0]))
            except ConfigError as exc:
                raise SweepError(f"{config}/{algo}: {exc}") from None


def run_sweep(
    sweep: Sweep,
    backend,
    log: Callable[[str], None] = print,
    advance: Callable[[int], None] | None = None,
) -> SweepRun:
    """Run what is not finished yet: finished runs are skipped, started ones resumed (after
    ``prepare_run``), the rest started, longest first. ``advance(n)`` is told of every run
    that is finished (those done before first), for a progress bar. Raises ``SweepError``
    when the output directory holds runs of another configuration, or another driver runs it."""
    with sweep_lock(sweep.out):
        return _run_sweep(sweep, backend, log, advance or (lambda n: None))


def _run_sweep(
    sweep: Sweep, backend, log: Callable[[str], None], advance: Callable[[int], None]
) -> SweepRun:
    specs = sweep.runs()
    states = {spec: inspect_run(spec, spec.dir(sweep.out)) for spec in specs}
    found = conflicts(states)
    if found:
        raise SweepError(conflict_message(sweep, found))
    todo = []
    for spec in specs:
        if states[spec].kind != DONE:
            states[spec] = prepare_run(spec, spec.dir(sweep.out), log)
            todo.append(spec)
    progress = {s: states[s].steps or 0 for s in todo}
    todo = longest_first(todo, progress)
    done_before = len(specs) - len(todo)
    advance(done_before)
    resumed = sum(bool(progress[s]) for s in todo)
    log(
        f"{sweep.out}: {len(specs)} runs: {done_before} done, {resumed} to resume, "
        f"{len(todo) - resumed} to start; estimated "
        f"{format_duration(estimate_wall(todo, backend.workers, progress))} with "
        f"{backend.workers} "
        f"{backend.name} worker{'s' if backend.workers != 1 else ''}"
    )
    by_name = {spec.name: spec for spec in todo}
    jobs = [
        Job(spec.name, str(spec.dir(sweep.out).resolve()), spec.train, backend.returns_results)
        for spec in todo
    ]
    outcomes: list = []
    start = datetime.datetime.now()
    clock = _Clock()

    def on_outcome(outcome) -> None:
        spec = by_name.get(outcome.name)
        if spec is not None and outcome.result is not None:
            if store_result(spec, spec.dir(sweep.out), outcome.result):
                log(f"{spec.name}: wrote the result returned by the worker")
            outcome = replace(outcome, result=None)
        outcomes.append(outcome)
        if outcome.status == "done":
            advance(1)
        finished = done_before + sum(o.status == "done" for o in outcomes)
        log(f"[{finished}/{len(specs)} done, {clock}] {describe_outcome(outcome, sweep)}")

    interrupted = backend.run(jobs, on_outcome) if jobs else False
    return SweepRun(
        len(specs),
        done_before,
        outcomes,
        bool(interrupted),
        (datetime.datetime.now() - start).total_seconds(),
    )


def describe_outcome(outcome, sweep: Sweep) -> str:
    """One line per finished, stopped or failed run."""
    if outcome.status == "done":
        f = outcome.final or {}
        text = f"{outcome.name}: return {f.get('return_mean', float('nan')):.2f}"
        if f.get("optimal_mean") is not None:
            text += f" (optimal {f['optimal_mean']:.2f})"
        return text + f", success {f.get('success_rate', 0):.0%}, {outcome.seconds:.0f} s"
    if outcome.status == "stopped":
        return f"{outcome.name}: {outcome.detail or 'stopped'} (resumable)"
    where = Path(sweep.out) / outcome.name / ERROR
    return f"{outcome.name}: FAILED: {outcome.error} (details: {where})"


class _Clock:
    """Elapsed time since creation, for progress lines."""

    def __init__(self) -> None:
        self.start = datetime.datetime.now()

    def __str__(self) -> str:
        seconds = (datetime.datetime.now() - self.start).total_seconds()
        return f"{format_duration(seconds)} elapsed"
