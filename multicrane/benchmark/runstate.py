"""The state of a run directory on disk: what it holds (done, partial, pending, failed,
corrupt, conflicting), repairs before a resume, and a result written for a remote worker.

The directory tree *is* the sweep's state, so a sweep resumes by looking at it: a run with a
valid ``result.json`` is done and never touched again; any other started run is handed to
``train`` again, which resumes from its checkpoint (or starts over when there is none). A
run's ``result.json`` holds its learning curve, final evaluation, configuration, package
versions and wall time. Reading here never imports torch.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from multicrane.benchmark.profiles import RunSpec, Sweep, jsonable
from multicrane.files import aside_path, write_atomic, write_json_atomic

RESULT = "result.json"
CONFIG = "config.json"
CHECKPOINT = "checkpoint"
ERROR = "error.txt"

DONE = "done"
PARTIAL = "partial"  # started: a checkpoint (or only config.json); train() resumes it
PENDING = "pending"  # nothing on disk yet
FAILED = "failed"  # the last attempt raised; error.txt says why; retried by the next `run`
CORRUPT = "corrupt"  # unreadable result.json or config.json; moved aside by prepare_run
CONFLICT = "conflict"  # the directory holds a run with another configuration
STATES = (DONE, PARTIAL, PENDING, FAILED, CORRUPT, CONFLICT)


@dataclass(frozen=True)
class RunState:
    kind: str
    detail: str = ""
    steps: int | None = None  # the checkpoint's step for partial runs


def read_json(path: Path) -> tuple[Any, str]:
    """(data, "") or (None, why it cannot be used)."""
    try:
        return json.loads(Path(path).read_text()), ""
    except FileNotFoundError:
        return None, f"{path}: missing"
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        return None, f"{path}: unreadable ({exc})"


def read_result(path: Path) -> tuple[dict | None, str]:
    """A run's result dict, or (None, the problem): unreadable JSON, or one of the entries
    the benchmark needs missing (a partial file)."""
    data, problem = read_json(path)
    if problem:
        return None, problem
    if not isinstance(data, dict):
        return None, f"{path}: not a JSON object"
    for key, kind in (("config", dict), ("final", dict), ("curve", list), ("steps", int)):
        if not isinstance(data.get(key), kind):
            return None, f"{path}: no valid {key!r} entry (a partial or foreign result file)"
    mean = data["final"].get("return_mean")
    if not isinstance(mean, int | float) or isinstance(mean, bool) or not math.isfinite(mean):
        return None, f"{path}: final.return_mean is {mean!r}, not a number"
    return data, ""


def config_differences(stored: dict, wanted: dict) -> list[str]:
    """``key: stored != wanted`` for each setting of the sweep that a stored run differs in.
    Only the sweep's keys are compared, so settings the trainer adds later do not count."""
    out = []
    for key, value in wanted.items():
        have = stored.get(key, value if value is None else "<absent>")
        if jsonable(have) != value:
            out.append(f"{key}: {have!r} != {value!r}")
    return out


def checkpoint_steps(run_dir: Path) -> int | None:
    """The step of the run's complete checkpoint, or None."""
    try:
        return int((run_dir / CHECKPOINT / "steps.txt").read_text().strip())
    except (OSError, ValueError):
        return None


def inspect_run(spec: RunSpec, run_dir: Path) -> RunState:
    """What is on disk for one run (reads files only; changes nothing)."""
    run_dir = Path(run_dir)
    result_path = run_dir / RESULT
    if result_path.exists():
        result, problem = read_result(result_path)
        if problem:
            return RunState(CORRUPT, problem)
        diff = config_differences(result["config"], spec.train)
        if diff:
            return RunState(CONFLICT, f"{result_path}: " + "; ".join(diff))
        return RunState(DONE)
    config_path = run_dir / CONFIG
    if config_path.exists():
        stored, problem = read_json(config_path)
        if problem or not isinstance(stored, dict):
            return RunState(CORRUPT, problem or f"{config_path}: not a JSON object")
        diff = config_differences(stored, spec.train)
        if diff:
            return RunState(CONFLICT, f"{config_path}: " + "; ".join(diff))
    steps = checkpoint_steps(run_dir)
    if steps is None:
        steps = _recoverable_checkpoint(run_dir)[1]
    error = run_dir / ERROR
    if error.exists():
        lines = error.read_text(errors="replace").strip().splitlines()
        return RunState(FAILED, lines[-1] if lines else str(error), steps)
    if steps is not None:
        return RunState(PARTIAL, f"checkpoint at step {steps}", steps)
    if config_path.exists():
        return RunState(PARTIAL, "started, no checkpoint yet (starts over)", 0)
    return RunState(PENDING)


def _recoverable_checkpoint(run_dir: Path) -> tuple[Path | None, int | None]:
    """A complete checkpoint left as ``checkpoint.tmp``/``checkpoint.old`` when a save was
    cut between its two renames, or the kept ``checkpoint.prev`` (``checkpoint/`` itself
    missing; see ``multicrane.training.checkpoints``)."""
    if (run_dir / CHECKPOINT).exists():
        return None, None
    for suffix in (".tmp", ".old", ".prev"):  # newest first
        candidate = run_dir / (CHECKPOINT + suffix)
        try:
            return candidate, int((candidate / "steps.txt").read_text().strip())
        except (OSError, ValueError):
            continue
    return None, None


def prepare_run(spec: RunSpec, run_dir: Path, log: Callable[[str], None] = print) -> RunState:
    """Make a run directory safe to hand to ``train``: move an unreadable ``result.json``
    aside (the run is then resumed or redone), move a directory with an unreadable
    ``config.json`` aside whole (it starts over), restore a checkpoint stranded by a cut
    save, and clear the last attempt's ``error.txt``. Returns the state afterwards."""
    run_dir = Path(run_dir)
    state = inspect_run(spec, run_dir)
    if state.kind == CORRUPT:
        result_path = run_dir / RESULT
        if result_path.exists() and read_result(result_path)[1]:
            aside = aside_path(result_path)
            result_path.rename(aside)
            log(f"{spec.name}: {state.detail}; moved it to {aside.name} and redo the run")
        state = inspect_run(spec, run_dir)
        if state.kind == CORRUPT:  # config.json
            aside = aside_path(run_dir)
            run_dir.rename(aside)
            log(f"{spec.name}: {state.detail}; moved the run directory to {aside}")
            state = inspect_run(spec, run_dir)
    if state.kind in (PARTIAL, FAILED):
        stranded, steps = _recoverable_checkpoint(run_dir)
        if stranded is not None:
            stranded.rename(run_dir / CHECKPOINT)
            log(f"{spec.name}: restored the checkpoint at step {steps} from {stranded.name}")
        (run_dir / ERROR).unlink(missing_ok=True)
        state = inspect_run(spec, run_dir)
    return state


def sweep_states(sweep: Sweep) -> dict[RunSpec, RunState]:
    return {spec: inspect_run(spec, spec.dir(sweep.out)) for spec in sweep.runs()}


def count_states(states: Iterable[RunState]) -> dict[str, int]:
    counts = dict.fromkeys(STATES, 0)
    for state in states:
        counts[state.kind] += 1
    return counts


def store_result(spec: RunSpec, run_dir: Path, result: dict) -> bool:
    """Write a result returned to the driver (Ray workers without a shared filesystem) as
    the run's ``config.json``/``result.json``, unless a valid result is already there.
    True when written."""
    run_dir = Path(run_dir)
    if inspect_run(spec, run_dir).kind == DONE:
        return False
    run_dir.mkdir(parents=True, exist_ok=True)
    if not (run_dir / CONFIG).exists():
        config = json.dumps(result["config"], indent=2, sort_keys=True) + "\n"
        write_atomic(run_dir / CONFIG, config)
    write_json_atomic(run_dir / RESULT, result, indent=1)
    return True


def conflicts(states: dict[RunSpec, RunState]) -> list[str]:
    return [f"{spec.name}: {st.detail}" for spec, st in states.items() if st.kind == CONFLICT]


def conflict_message(sweep: Sweep, found: list[str]) -> str:
    shown = "\n  ".join(found[:5])
    if len(found) > 5:
        shown += f"\n  ... and {len(found) - 5} more"
    return (
        f"{sweep.out} holds {len(found)} run(s) with another configuration than this sweep "
        f"(an older budget?):\n  {shown}\nUse another --out, or delete {sweep.out} to start "
        "over."
    )
