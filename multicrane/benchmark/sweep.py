"""Benchmark sweeps: budget profiles, the runs they expand to, their directories, resume.

A sweep is configurations x algorithms x seeds under one budget. Each run is one
``multicrane.training.train`` run directory, ``<out>/<CONFIG>/<algo>/seed<k>/``, whose
``result.json`` is the run's result file (learning curve, final evaluation, configuration,
package versions, wall time). The directory tree *is* the sweep's state, so a sweep resumes
by looking at it: a run with a valid ``result.json`` is done and never touched again; any
other started run is handed to ``train`` again, which resumes from its checkpoint (or
starts over when there is none). Nothing here imports torch: ``status`` and ``report`` only
read JSON files.

``<out>/sweep.json`` records what the sweep is and the sessions that ran it (command,
machine, dates), for the labels of the report.
"""

from __future__ import annotations

import datetime
import fcntl
import heapq
import json
import math
import os
from collections.abc import Callable, Iterable, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from multicrane.paper_env import PAPER_CONFIGS

ALGOS = ("dqn", "double_dqn", "a2c", "ppo", "maskable_ppo")
# The four algorithms the paper's text describes (vanilla DQN, double DQN, A2C, PPO).
PAPER_ALGOS = ("dqn", "double_dqn", "a2c", "ppo")
DEFAULT_ROOT = Path("runs") / "bench"
MANIFEST = "sweep.json"
RESULT = "result.json"
CONFIG = "config.json"
CHECKPOINT = "checkpoint"
ERROR = "error.txt"
LOCK = ".lock"


class SweepError(ValueError):
    """A sweep that cannot be set up or run; the message names the option, value or file."""


# -- profiles ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Profile:
    """A named budget: which runs, and how long each trains and is evaluated.

    ``hyperparams`` and ``n_envs`` are per algorithm (``TrainConfig.hyperparams`` /
    ``n_envs``); absent algorithms use the paper's settings.
    """

    name: str
    configs: tuple[str, ...]
    algos: tuple[str, ...]
    seeds: tuple[int, ...]
    steps: int
    eval_every: int
    eval_episodes: int
    checkpoint_every: int
    about: str
    final_episodes: int | None = None  # the final evaluation (default: eval_episodes)
    hyperparams: dict[str, dict[str, Any]] = field(default_factory=dict)
    n_envs: dict[str, int] = field(default_factory=dict)


ENV1_ENV2 = tuple(c for c in PAPER_CONFIGS if c[:2] in ("E1", "E2"))

PROFILES: dict[str, Profile] = {
    p.name: p
    for p in (
        Profile(
            name="smoke",
            configs=("E1S1", "E2S2"),
            algos=ALGOS,
            seeds=(0,),
            steps=1_000,
            eval_every=500,
            eval_episodes=3,
            checkpoint_every=0,
            about="seconds: tries every algorithm once on two configurations (CI, trying "
            "the tool); learns nothing",
        ),
        # The quick profile: about 35 minutes with 2 workers on a 2-core machine (see
        # docs/benchmark.md for the estimate). DQN and double DQN take 90 % of the time
        # (one gradient step per environment step, ~450 steps/s); change `steps` or
        # `seeds` here to resize it.
        Profile(
            name="quick",
            configs=ENV1_ENV2,
            algos=ALGOS,
            seeds=(0, 1, 2),
            steps=30_000,
            eval_every=3_000,
            eval_episodes=10,
            final_episodes=50,
            checkpoint_every=0,  # runs of a minute: a checkpoint only when interrupted
            about="about 35 min on 2 cores: Env1 and Env2 (8 configurations), all five "
            "algorithms, 3 seeds, 30,000 steps per run",
        ),
        Profile(
            name="paper",
            configs=PAPER_CONFIGS,
            algos=PAPER_ALGOS,
            seeds=tuple(range(15)),
            steps=1_000_000,
            eval_every=10_000,
            eval_episodes=10,
            final_episodes=100,
            checkpoint_every=100_000,
            about="the paper's protocol: 16 configurations, DQN / double DQN / A2C / PPO, "
            "15 seeds, 1,000,000 steps per run, a curve point every 10,000 steps (the "
            "paper's epoch) over 10 episodes (Fig. 7); days of CPU time, meant for a cluster",
        ),
    )
}


# -- runs and sweeps -----------------------------------------------------------------------------


@dataclass(frozen=True)
class RunSpec:
    """One run of a sweep: its place in the grid and its ``TrainConfig`` keyword arguments."""

    config: str
    algo: str
    seed: int
    train: dict[str, Any] = field(compare=False)  # a run is known by (config, algo, seed)

    @property
    def name(self) -> str:
        return f"{self.config}/{self.algo}/seed{self.seed}"

    def dir(self, out: Path) -> Path:
        return Path(out) / self.config / self.algo / f"seed{self.seed}"


@dataclass(frozen=True)
class Sweep:
    """A profile with the command line's choices applied, and where its runs live."""

    name: str
    profile: str
    out: Path
    configs: tuple[str, ...]
    algos: tuple[str, ...]
    seeds: tuple[int, ...]
    steps: int
    eval_every: int
    eval_episodes: int
    checkpoint_every: int
    final_episodes: int | None = None
    hyperparams: dict[str, dict[str, Any]] = field(default_factory=dict)
    n_envs: dict[str, int] = field(default_factory=dict)

    def runs(self) -> list[RunSpec]:
        """Every run, configuration-major, then algorithm, then seed."""
        return [
            RunSpec(config, algo, seed, self.train_kwargs(config, algo, seed))
            for config in self.configs
            for algo in self.algos
            for seed in self.seeds
        ]

    def train_kwargs(self, config: str, algo: str, seed: int) -> dict[str, Any]:
        return _jsonable(
            {
                "scenario": config,
                "paper": True,
                "algo": algo,
                "total_steps": self.steps,
                "seed": seed,
                "n_envs": self.n_envs.get(algo),
                "hyperparams": self.hyperparams.get(algo, {}),
                "eval_every": self.eval_every,
                "eval_episodes": self.eval_episodes,
                "final_episodes": self.final_episodes,
                "checkpoint_every": self.checkpoint_every,
                "torch_threads": 1,
            }
        )

    def budget(self) -> str:
        """One line: steps, seeds, evaluations."""
        return (
            f"{self.steps:,} environment steps per run, {len(self.seeds)} seed"
            f"{'s' if len(self.seeds) != 1 else ''} ({format_seeds(self.seeds)}), "
            f"curve evaluations every {self.eval_every:,} steps over {self.eval_episodes} "
            f"episodes, final evaluation over {self.final_episodes or self.eval_episodes} episodes"
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "profile": self.profile,
            "configs": list(self.configs),
            "algos": list(self.algos),
            "seeds": list(self.seeds),
            "steps": self.steps,
            "eval_every": self.eval_every,
            "eval_episodes": self.eval_episodes,
            "final_episodes": self.final_episodes,
            "checkpoint_every": self.checkpoint_every,
            "hyperparams": _jsonable(self.hyperparams),
            "n_envs": dict(self.n_envs),
        }


def make_sweep(
    profile: str | Profile = "smoke",
    *,
    configs: Sequence[str] | None = None,
    algos: Sequence[str] | None = None,
    seeds: Sequence[int] | None = None,
    steps: int | None = None,
    eval_every: int | None = None,
    eval_episodes: int | None = None,
    out: str | Path | None = None,
    root: str | Path = DEFAULT_ROOT,
) -> Sweep:
    """The profile with the given choices. ``configs``/``algos``/``seeds`` pick runs (they
    share directories with the whole profile); ``steps``/``eval_every``/``eval_episodes``
    change every run, so unless ``out`` is given such a sweep gets its own directory
    (``<root>/<profile>-<steps>steps-eval<every>x<episodes>``)."""
    if isinstance(profile, str):
        if profile not in PROFILES:
            raise SweepError(f"unknown profile {profile!r}: one of {', '.join(PROFILES)}")
        profile = PROFILES[profile]
    chosen_configs = parse_configs(configs) if configs else profile.configs
    chosen_algos = tuple(algos) if algos else profile.algos
    for algo in chosen_algos:
        if algo not in ALGOS:
            raise SweepError(f"unknown algorithm {algo!r}: one of {', '.join(ALGOS)}")
    chosen_seeds = tuple(seeds) if seeds is not None and len(seeds) else profile.seeds
    for seed in chosen_seeds:
        if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
            raise SweepError(f"seed {seed!r}: seeds are non-negative integers")
    for label, values in (
        ("configuration", chosen_configs),
        ("algorithm", chosen_algos),
        ("seed", chosen_seeds),
    ):
        twice = sorted({str(v) for v in values if list(values).count(v) > 1})
        if twice:
            raise SweepError(f"{label} given twice: {', '.join(twice)}")
    budget = {
        "steps": profile.steps if steps is None else steps,
        "eval_every": profile.eval_every if eval_every is None else eval_every,
        "eval_episodes": profile.eval_episodes if eval_episodes is None else eval_episodes,
    }
    for key, value in budget.items():
        low = 0 if key == "eval_every" else 1
        if not isinstance(value, int) or isinstance(value, bool) or value < low:
            raise SweepError(f"{key}={value!r}: must be an integer >= {low}")
    custom = (budget["steps"], budget["eval_every"], budget["eval_episodes"]) != (
        profile.steps,
        profile.eval_every,
        profile.eval_episodes,
    )
    name = profile.name
    if custom:
        name = (
            f"{profile.name}-{budget['steps']}steps-eval{budget['eval_every']}"
            f"x{budget['eval_episodes']}"
        )
    return Sweep(
        name=name,
        profile=profile.name,
        out=Path(out) if out is not None else Path(root) / name,
        configs=chosen_configs,
        algos=chosen_algos,
        seeds=chosen_seeds,
        checkpoint_every=profile.checkpoint_every,
        final_episodes=profile.final_episodes,
        hyperparams={a: dict(h) for a, h in profile.hyperparams.items() if a in chosen_algos},
        n_envs={a: n for a, n in profile.n_envs.items() if a in chosen_algos},
        **budget,
    )


def parse_configs(items: Iterable[str]) -> tuple[str, ...]:
    """``E1S1`` .. ``E4S4``, ``E2`` (its four scenarios) or ``all``, in paper order."""
    chosen: set[str] = set()
    for item in items:
        token = item.strip().upper()
        if token == "ALL":
            chosen.update(PAPER_CONFIGS)
        elif token in PAPER_CONFIGS:
            chosen.add(token)
        elif token in ("E1", "E2", "E3", "E4"):
            chosen.update(c for c in PAPER_CONFIGS if c.startswith(token))
        else:
            raise SweepError(
                f"unknown configuration {item!r}: E1S1 .. E4S4, E1 .. E4 (an environment's "
                "four scenarios) or all"
            )
    return tuple(c for c in PAPER_CONFIGS if c in chosen)


def parse_seeds(items: Iterable[str]) -> tuple[int, ...]:
    """``0 1 2``, ``0-14`` or ``0,3,5``."""
    seeds: list[int] = []
    for item in items:
        for part in str(item).split(","):
            part = part.strip()
            if not part:
                continue
            first, dash, last = part.partition("-")
            try:
                if dash:
                    lo, hi = int(first), int(last)
                    if hi < lo:
                        raise ValueError
                    seeds.extend(range(lo, hi + 1))
                else:
                    seeds.append(int(part))
            except ValueError:
                raise SweepError(f"seeds {item!r}: expected integers or ranges like 0-14") from None
    return tuple(seeds)


def format_seeds(seeds: Sequence[int]) -> str:
    """``0-14`` for a contiguous range, else the list."""
    seeds = list(seeds)
    if len(seeds) > 2 and seeds == list(range(seeds[0], seeds[0] + len(seeds))):
        return f"{seeds[0]}-{seeds[-1]}"
    return ", ".join(str(s) for s in seeds)


# -- the state of a run on disk ------------------------------------------------------------------

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
        if _jsonable(have) != value:
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
    cut between its two renames (``checkpoint/`` itself missing)."""
    if (run_dir / CHECKPOINT).exists():
        return None, None
    for suffix in (".tmp", ".old"):  # .tmp is the newer one
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
            aside = _aside(result_path)
            result_path.rename(aside)
            log(f"{spec.name}: {state.detail}; moved it to {aside.name} and redo the run")
        state = inspect_run(spec, run_dir)
        if state.kind == CORRUPT:  # config.json
            aside = _aside(run_dir)
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


def _aside(path: Path) -> Path:
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    candidate = path.with_name(f"{path.name}.corrupt-{stamp}")
    n = 1
    while candidate.exists():
        n += 1
        candidate = path.with_name(f"{path.name}.corrupt-{stamp}-{n}")
    return candidate


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
        write_atomic(run_dir / CONFIG, json.dumps(result["config"], indent=2, sort_keys=True))
    write_atomic(run_dir / RESULT, json.dumps(result, indent=1) + "\n")
    return True


def write_atomic(path: Path, text: str) -> None:
    """Through a temporary file and a rename: a reader never sees half a file."""
    path = Path(path)
    tmp = path.with_name(f"{path.name}.tmp-{os.getpid()}")
    tmp.write_text(text if text.endswith("\n") else text + "\n")
    tmp.replace(path)


# -- the manifest --------------------------------------------------------------------------------


def read_manifest(out: Path) -> dict:
    data, problem = read_json(Path(out) / MANIFEST)
    return data if not problem and isinstance(data, dict) else {}


def record_session(sweep: Sweep, session: dict[str, Any]) -> None:
    """Add one session (command, backend, machine, start and end) to ``sweep.json``."""
    sweep.out.mkdir(parents=True, exist_ok=True)
    manifest = read_manifest(sweep.out)
    sessions = manifest.get("sessions", []) if isinstance(manifest.get("sessions"), list) else []
    manifest = {**sweep.to_dict(), "sessions": [*sessions, session]}
    write_atomic(sweep.out / MANIFEST, json.dumps(manifest, indent=2))


# -- cost estimate -------------------------------------------------------------------------------

# Training steps per second of one process with one torch thread, measured on the 2-core
# development machine (paper settings; the environment itself runs at 25,000+ steps/s in
# every configuration, so the learner sets the pace).
THROUGHPUT = {"dqn": 450, "double_dqn": 450, "a2c": 5000, "ppo": 3000, "maskable_ppo": 2500}
# Greedy evaluation: seconds per environment step (model prediction + environment), and
# the step limit of an episode (an untrained policy runs to it).
EVAL_STEP_SECONDS = 0.00025
EPISODE_LIMIT = {"E1": 100, "E2": 100, "E3": 300, "E4": 600}
RUN_OVERHEAD_SECONDS = 1.0  # building the environments and model, writing files


def estimate_seconds(spec: RunSpec, done_steps: int = 0) -> float:
    """CPU seconds of one run (of what is left after ``done_steps``): training at
    ``THROUGHPUT``, plus curve points and the final evaluation with every episode at the
    step limit (the pessimistic case)."""
    t = spec.train
    left = max(0, t["total_steps"] - done_steps)
    train = left / THROUGHPUT[spec.algo]
    points = (left // t["eval_every"] + 2) if t["eval_every"] else 1
    episode = EPISODE_LIMIT[spec.config[:2]] * EVAL_STEP_SECONDS
    return train + points * t["eval_episodes"] * episode + RUN_OVERHEAD_SECONDS


def estimate_wall(
    specs: Sequence[RunSpec], workers: int, done_steps: dict[RunSpec, int] | None = None
) -> float:
    """Wall seconds with ``workers`` processes, longest runs first (as the backends order
    them), each process starting up once (~3 s: importing torch). ``done_steps``: steps
    already in the checkpoints of partial runs."""
    done_steps = done_steps or {}
    loads = [3.0] * max(1, min(workers, len(specs)))
    heapq.heapify(loads)
    costs = (estimate_seconds(s, done_steps.get(s) or 0) for s in specs)
    for cost in sorted(costs, reverse=True):
        heapq.heappush(loads, heapq.heappop(loads) + cost)
    return max(loads) if specs else 0.0


def longest_first(
    specs: Iterable[RunSpec], done_steps: dict[RunSpec, int] | None = None
) -> list[RunSpec]:
    done_steps = done_steps or {}
    return sorted(specs, key=lambda s: estimate_seconds(s, done_steps.get(s) or 0), reverse=True)


def format_duration(seconds: float) -> str:
    seconds = int(round(seconds))
    if seconds < 120:
        return f"{seconds} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    if seconds < 3 * 86400:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / 86400:.1f} days"


# -- running a sweep -----------------------------------------------------------------------------


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


@contextmanager
def sweep_lock(out: Path):
    """Hold ``<out>/.lock`` while a sweep runs: two drivers training the same run
    directories would overwrite each other's checkpoints."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / LOCK, "a+") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            f.seek(0)
            holder = f.read().strip() or "another process"
            raise SweepError(
                f"{out} is being run by {holder}: wait for it, or stop it (Ctrl-C) first"
            ) from None
        f.seek(0)
        f.truncate()
        f.write(f"pid {os.getpid()}\n")
        f.flush()
        try:
            yield
        finally:
            f.truncate(0)
            fcntl.flock(f, fcntl.LOCK_UN)


def run_sweep(sweep: Sweep, backend, log: Callable[[str], None] = print) -> SweepRun:
    """Run what is not finished yet: finished runs are skipped, started ones resumed (after
    ``prepare_run``), the rest started, longest first. Raises ``SweepError`` when the
    output directory holds runs of another configuration, or another driver runs it."""
    with sweep_lock(sweep.out):
        return _run_sweep(sweep, backend, log)


def _run_sweep(sweep: Sweep, backend, log: Callable[[str], None]) -> SweepRun:
    from multicrane.benchmark.backends import Task

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
    resumed = sum(bool(progress[s]) for s in todo)
    log(
        f"{sweep.out}: {len(specs)} runs: {done_before} done, {resumed} to resume, "
        f"{len(todo) - resumed} to start; estimated "
        f"{format_duration(estimate_wall(todo, backend.workers, progress))} with "
        f"{backend.workers} "
        f"{backend.name} worker{'s' if backend.workers != 1 else ''}"
    )
    by_name = {spec.name: spec for spec in todo}
    tasks = [
        Task(spec.name, str(spec.dir(sweep.out).resolve()), spec.train, backend.returns_results)
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
        finished = done_before + sum(o.status == "done" for o in outcomes)
        log(f"[{finished}/{len(specs)} done, {clock}] {describe_outcome(outcome, sweep)}")

    interrupted = backend.run(tasks, on_outcome) if tasks else False
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


# -- helpers -------------------------------------------------------------------------------------


def _jsonable(value: Any) -> Any:
    """The value as it reads back from JSON (tuples become lists), for comparisons."""
    return json.loads(json.dumps(value))
