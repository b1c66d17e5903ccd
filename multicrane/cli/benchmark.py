"""`multicrane benchmark`: run, resume, inspect and report sweeps of the paper's algorithms x
configurations x seeds (the command-line front end of ``multicrane.benchmark``)."""

from __future__ import annotations

import argparse
import datetime
import importlib.util
import os
import sys
from collections.abc import Callable
from pathlib import Path

from multicrane.benchmark.choices import SweepError, parse_seeds
from multicrane.benchmark.estimate import estimate_wall, format_duration
from multicrane.benchmark.manifest import record_session, session_labels
from multicrane.benchmark.profiles import (
    DEFAULT_ROOT,
    PROFILES,
    RUNNABLE_ALGOS,
    Sweep,
    make_sweep,
)
from multicrane.benchmark.runstate import (
    DONE,
    PENDING,
    STATES,
    conflict_message,
    conflicts,
    count_states,
    sweep_states,
)
from multicrane.cli import progress

EXAMPLES = """\
examples:
  multicrane benchmark profiles                         # what each profile runs
  multicrane benchmark run --profile smoke              # seconds: try the tool
  multicrane benchmark run --profile quick --workers 2  # ~35 min on 2 cores
  multicrane benchmark run --profile standard --workers 2  # Table I complete, ~1.5 h on 2 cores
  multicrane benchmark status --profile quick           # done / partial / pending
  multicrane benchmark report --profile quick --docs    # table + curves into docs/
  multicrane benchmark run --profile paper --configs E3 --algos ppo --seeds 0-4
  multicrane benchmark run --profile paper --backend ray --address auto

Each run trains with multicrane.training.train in its own directory,
<out>/<CONFIG>/<algo>/seed<k>/ (--out, default runs/bench/<sweep>), whose result.json holds
the learning curve, the final evaluation, the configuration, package versions and wall time.
Running the same command again skips finished runs, resumes interrupted ones from their
checkpoints and redoes runs whose result file is unreadable. Ctrl-C stops the running runs at
their next update with a checkpoint (twice: at once).

--configs/--algos/--seeds pick runs out of the profile (the same directories);
--steps/--eval-every/--eval-episodes change the budget of every run, which makes a sweep of
its own (runs/bench/<profile>-<steps>steps-eval<every>x<episodes>). status and report take
the same options to find the sweep. See docs/benchmark.md.
"""

DOCS_FILE = Path("docs") / "benchmark.md"  # from the repository root


def register(subparsers) -> None:
    """Add ``benchmark`` and its actions (profiles, run, status, report)."""
    p = subparsers.add_parser(
        "benchmark",
        help="the paper's algorithms x configurations x seeds: run, status, report",
        description="Run, resume, inspect and report sweeps of the paper's algorithms x "
        "configurations x seeds.",
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    sub = p.add_subparsers(dest="action", required=True, metavar="ACTION")
    sub.add_parser("profiles", help="list the profiles").set_defaults(func=_guard(cmd_profiles))

    run = sub.add_parser("run", help="run (or resume) a sweep")
    _selection(run)
    run.add_argument(
        "--workers",
        type=int,
        default=None,
        help=f"parallel runs (default: cores, {os.cpu_count()}; Ray: local instance's CPUs)",
    )
    run.add_argument("--backend", choices=("local", "ray", "serial"), default="local")
    run.add_argument(
        "--address",
        default=None,
        help="Ray: 'auto' (this machine's cluster) or ray://host:10001 (default: a local "
        "Ray instance)",
    )
    run.add_argument("--dry-run", action="store_true", help="show the plan, run nothing")
    run.set_defaults(func=_guard(cmd_run))

    status = sub.add_parser("status", help="done / partial / pending runs of a sweep")
    _selection(status)
    status.add_argument("--workers", type=int, default=None, help="for the time estimate")
    status.set_defaults(func=_guard(cmd_status))

    report = sub.add_parser("report", help="aggregate a sweep: markdown, JSON, plots")
    _selection(report)
    report.add_argument(
        "--docs",
        action="store_true",
        help=f"also write the table into {DOCS_FILE} (the sweep's generated section) and the "
        "plots into docs/benchmark/ (run from the repository root)",
    )
    report.add_argument("--docs-file", type=Path, default=DOCS_FILE, help=argparse.SUPPRESS)
    report.add_argument("--no-plots", action="store_true", help="skip the PNG curves")
    report.set_defaults(func=_guard(cmd_report))


def main(argv: list[str] | None = None) -> int:
    """``multicrane benchmark ARGV``, on its own (developers, tests)."""
    parser = argparse.ArgumentParser(prog="multicrane")
    register(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(["benchmark", *(sys.argv[1:] if argv is None else argv)])
    return args.func(args)


# -- shared pieces -----------------------------------------------------------------------------

SELECTION = (
    ("--configs", "configs"),
    ("--algos", "algos"),
    ("--seeds", "seeds"),
    ("--steps", "steps"),
    ("--eval-every", "eval_every"),
    ("--eval-episodes", "eval_episodes"),
    ("--out", "out"),
)


def _selection(p: argparse.ArgumentParser) -> None:
    p.add_argument("--profile", default="smoke", choices=list(PROFILES), help="budget profile")
    p.add_argument(
        "--configs",
        nargs="+",
        metavar="CONFIG",
        help="E1S1 .. E4S4, E1 .. E4 (four scenarios) or all (default: the profile's)",
    )
    p.add_argument("--algos", nargs="+", choices=RUNNABLE_ALGOS, help="default: the profile's")
    p.add_argument(
        "--seeds", nargs="+", metavar="SEED", help="e.g. 0 1 2 or 0-14 (default: the profile's)"
    )
    p.add_argument("--steps", type=int, help="environment steps per run (default: profile's)")
    p.add_argument("--eval-every", type=int, help="steps between curve points")
    p.add_argument("--eval-episodes", type=int, help="episodes per evaluation")
    p.add_argument("--out", type=Path, help=f"sweep directory (default {DEFAULT_ROOT}/<sweep>)")


def sweep_from(args: argparse.Namespace) -> Sweep:
    return make_sweep(
        args.profile,
        configs=args.configs,
        algos=args.algos,
        seeds=parse_seeds(args.seeds) if args.seeds else None,
        steps=args.steps,
        eval_every=args.eval_every,
        eval_episodes=args.eval_episodes,
        out=args.out,
    )


def command(action: str, args: argparse.Namespace, *flags: tuple[str, str]) -> str:
    """The ``multicrane benchmark`` command line of ``action`` with the sweep selection of
    ``args`` and the given extra ``(flag, attribute)`` options that are set."""
    from multicrane.reports.provenance import command_line

    words: list[object] = ["benchmark", action, "--profile", args.profile]
    for flag, name in (*SELECTION, *flags):
        value = getattr(args, name, None)
        if value is None or value is False or (flag, value) == ("--backend", "local"):
            continue
        words.append(flag)
        if isinstance(value, list):
            words += value
        elif value is not True:
            words.append(value)
    return command_line(words)


def _guard(func: Callable[[argparse.Namespace], int]) -> Callable[[argparse.Namespace], int]:
    """``func`` with the sweep's errors as one line and exit status 2; progress lines
    reach a log file at once."""

    def guarded(args: argparse.Namespace) -> int:
        if hasattr(sys.stdout, "reconfigure"):
            sys.stdout.reconfigure(line_buffering=True)
        try:
            return func(args)
        except (SweepError, RuntimeError) as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 2
        except KeyboardInterrupt:
            print("interrupted", file=sys.stderr)
            return 130

    return guarded


def _missing(*modules: str) -> bool:
    for module in modules:
        try:
            if importlib.util.find_spec(module) is None:
                return True
        except (ImportError, ValueError):
            return True
    return False


def _needs(action: str, extra: str, note: str = "") -> int:
    print(
        f"multicrane benchmark {action} needs the '{extra}' extra: "
        f"pip install 'multicrane[{extra}]'{note}",
        file=sys.stderr,
    )
    return 2


# -- the actions -------------------------------------------------------------------------------


def cmd_profiles(_args: argparse.Namespace) -> int:
    workers = os.cpu_count() or 1
    for name in PROFILES:
        sweep = make_sweep(name)
        runs = sweep.runs()
        print(f"{name}: {PROFILES[name].about}")
        print(
            f"  {len(sweep.configs)} configurations x {len(sweep.algos)} algorithms "
            f"({', '.join(sweep.algos)}) x {len(sweep.seeds)} seed(s) = {len(runs)} runs; "
            f"{sweep.budget()}"
        )
        print(
            f"  estimated {format_duration(estimate_wall(runs, workers))} with {workers} "
            f"workers; directory {sweep.out}"
        )
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    sweep = sweep_from(args)
    if args.dry_run:
        return show_status(sweep, args.workers or os.cpu_count() or 1, plan=True)
    if args.backend == "ray" and _missing("ray"):
        return _needs("run --backend ray", "ray")
    if args.backend != "ray" and _missing("torch", "stable_baselines3", "sb3_contrib"):
        return _needs("run", "train")
    from multicrane.benchmark.backends import make_backend
    from multicrane.benchmark.sweep import run_sweep, validate_configs
    from multicrane.reports.provenance import machine

    validate_configs(sweep)
    backend = make_backend(args.backend, args.workers, args.address)
    started = datetime.datetime.now()
    print(f"sweep {sweep.name}: {sweep.budget()}")
    flags = (("--workers", "workers"), ("--backend", "backend"), ("--address", "address"))

    def session(outcome) -> dict:
        return {
            "command": command("run", args, *flags),
            "backend": args.backend,
            "address": args.address,
            "workers": backend.workers,
            "started": started.isoformat(timespec="seconds"),
            "finished": datetime.datetime.now().isoformat(timespec="seconds"),
            "machine": machine(),
            "finished_runs": None if outcome is None else outcome.count("done"),
            "failed_runs": None if outcome is None else len(outcome.failed),
            "interrupted": True if outcome is None else outcome.interrupted,
        }

    try:
        with progress.bar(total=len(sweep.runs()), desc=f"sweep {sweep.name}") as advance:
            outcome = run_sweep(sweep, backend, advance=advance)
    except SweepError:
        raise  # refused before anything ran
    except BaseException:
        record_session(sweep, session(None))
        raise
    record_session(sweep, session(outcome))
    stopped = outcome.count("stopped")
    print(
        f"{sweep.out}: {outcome.done_before + outcome.count('done')} of {outcome.total} runs "
        f"done ({outcome.count('done')} in this session, {format_duration(outcome.seconds)})"
        + (f", {stopped} stopped with a checkpoint" if stopped else "")
        + (f", {len(outcome.failed)} failed" if outcome.failed else "")
    )
    for failed in outcome.failed:
        print(f"  failed: {failed.name}: {failed.error}")
    if outcome.interrupted:
        print("interrupted: run the same command again to resume")
        return 130
    if outcome.failed:
        print("run the same command again to retry the failed runs")
        return 1
    if outcome.complete:
        print(f"report: {command('report', args)}")
    return 0


def show_status(sweep: Sweep, workers: int, plan: bool = False) -> int:
    states = sweep_states(sweep)
    counts = count_states(states.values())
    print(f"{sweep.out} ({sweep.name}: {sweep.budget()})")
    print(f"{len(states)} runs: " + ", ".join(f"{counts[k]} {k}" for k in STATES if counts[k]))
    width = max(max(len(a) for a in sweep.algos) + 2, 12)
    print("config  " + "".join(f"{a:>{width}}" for a in sweep.algos))
    for config in sweep.configs:
        cells = []
        for algo in sweep.algos:
            mine = [st for spec, st in states.items() if (spec.config, spec.algo) == (config, algo)]
            text = f"{sum(st.kind == DONE for st in mine)}/{len(mine)}"
            other = sum(st.kind not in (DONE, PENDING) for st in mine)
            if other:
                text += f" +{other}"
            cells.append(f"{text:>{width}}")
        print(f"{config:<8}" + "".join(cells))
    print("(done/total; +n: partial, failed, corrupt or conflicting runs, listed below)")
    for spec, st in states.items():
        if st.kind not in (DONE, PENDING):
            print(f"  {spec.name}: {st.kind}: {st.detail}")
    todo = [spec for spec, st in states.items() if st.kind != DONE]
    if todo:
        progress = {spec: states[spec].steps or 0 for spec in todo}
        left = format_duration(estimate_wall(todo, workers, progress))
        print(
            f"left: {len(todo)} runs, estimated {left} "
            f"with {workers} worker{'s' if workers != 1 else ''}"
        )
    found = conflicts(states)
    if found:
        print(conflict_message(sweep, found), file=sys.stderr)
    if plan:
        print("dry run: nothing started")
    return 0


def cmd_status(args: argparse.Namespace) -> int:
    return show_status(sweep_from(args), args.workers or os.cpu_count() or 1)


def baseline(sweep: Sweep) -> dict:
    """The uniform random policy's and the exact planner's mean return per configuration on
    the final evaluation's episodes, for the normalised score (``multicrane.benchmark.scores``)."""
    import policies
    from multicrane.benchmark.scores import baselines

    episodes = sweep.final_episodes or sweep.eval_episodes
    return baselines(sweep.configs, episodes, policies.factory("random", paper=True))


def cmd_report(args: argparse.Namespace) -> int:
    sweep = sweep_from(args)
    if not sweep.out.is_dir():
        print(f"error: {sweep.out}: no such sweep directory (run it first)", file=sys.stderr)
        return 2
    if not args.no_plots and _missing("matplotlib"):
        return _needs("report", "bench", " (or --no-plots)")
    docs_file = args.docs_file if args.docs else None
    if docs_file is not None and not docs_file.parent.is_dir():
        where = docs_file.parent
        print(f"error: {where}: no such directory (run from the repository root)", file=sys.stderr)
        return 2
    from multicrane.benchmark.report import write_report
    from multicrane.reports.provenance import machine

    labels = session_labels(sweep)
    flags = (("--docs", "docs"), ("--no-plots", "no_plots"))
    labels["report_command"] = f"`{command('report', args, *flags)}`"
    labels["date"] = f"report {datetime.date.today().isoformat()}" + (
        f"; {labels['date']}" if labels.get("date") else ""
    )
    labels.setdefault("machine", machine())
    cells = write_report(
        sweep, labels, docs_file, plots=not args.no_plots, baseline=baseline(sweep)
    )
    finished = sum(c.n for c in cells)
    total = sum(len(c.seeds) for c in cells)
    if finished < total:
        print(f"note: {total - finished} of {total} runs have no result yet (shown as pending)")
    return 0
