"""The benchmark: the paper's algorithms x configurations x seeds, resumable, with a report.

    python tools/benchmark.py profiles                         # what each profile runs
    python tools/benchmark.py run --profile smoke              # seconds: try the tool
    python tools/benchmark.py run --profile quick --workers 2  # ~35 min on 2 cores
    python tools/benchmark.py status --profile quick           # done / partial / pending
    python tools/benchmark.py report --profile quick --docs    # table + curves into docs/
    python tools/benchmark.py run --profile paper --configs E3 --algos ppo --seeds 0-4
    python tools/benchmark.py run --profile paper --backend ray --address auto

Each run trains with ``multicrane.training.train`` in its own directory,
``<out>/<CONFIG>/<algo>/seed<k>/`` (``--out``, default ``runs/bench/<sweep>``), and its
``result.json`` holds the learning curve, the final evaluation, the configuration, package
versions and wall time. Running the same command again skips finished runs, resumes
interrupted ones from their checkpoints and redoes runs whose result file is unreadable.
Ctrl-C stops the running runs at their next update with a checkpoint (twice: at once).

``--configs``/``--algos``/``--seeds`` pick runs out of the profile (the same directories);
``--steps``/``--eval-every``/``--eval-episodes`` change the budget of every run, which
makes a sweep of its own (``runs/bench/<profile>-<steps>steps-eval<every>x<episodes>``).
``status`` and ``report`` take the same options to find the sweep. See docs/benchmark.md.
"""

from __future__ import annotations

import argparse
import datetime
import os
import re
import shlex
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from multicrane.benchmark import aggregate  # noqa: E402
from multicrane.benchmark.sweep import (  # noqa: E402
    ALGOS,
    DEFAULT_ROOT,
    DONE,
    PENDING,
    PROFILES,
    STATES,
    Sweep,
    SweepError,
    conflict_message,
    conflicts,
    count_states,
    estimate_wall,
    format_duration,
    make_sweep,
    parse_seeds,
    read_manifest,
    record_session,
    run_sweep,
    sweep_states,
    validate_configs,
    write_atomic,
)
from tools.report import command_line, machine  # noqa: E402

DOCS_FILE = ROOT / "docs" / "benchmark.md"


# -- command line ------------------------------------------------------------------------------


def _selection(p: argparse.ArgumentParser) -> None:
    p.add_argument("--profile", default="smoke", choices=list(PROFILES), help="budget profile")
    p.add_argument(
        "--configs",
        nargs="+",
        metavar="CONFIG",
        help="E1S1 .. E4S4, E1 .. E4 (four scenarios) or all (default: the profile's)",
    )
    p.add_argument("--algos", nargs="+", choices=ALGOS, help="default: the profile's")
    p.add_argument(
        "--seeds", nargs="+", metavar="SEED", help="e.g. 0 1 2 or 0-14 (default: the profile's)"
    )
    p.add_argument("--steps", type=int, help="environment steps per run (default: profile's)")
    p.add_argument("--eval-every", type=int, help="steps between curve points")
    p.add_argument("--eval-episodes", type=int, help="episodes per evaluation")
    p.add_argument("--out", type=Path, help=f"sweep directory (default {DEFAULT_ROOT}/<sweep>)")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    sub = p.add_subparsers(dest="command", required=True)
    sub.add_parser("profiles", help="list the profiles")
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
    status = sub.add_parser("status", help="done / partial / pending runs of a sweep")
    _selection(status)
    status.add_argument("--workers", type=int, default=None, help="for the time estimate")
    report = sub.add_parser("report", help="aggregate a sweep: markdown, JSON, plots")
    _selection(report)
    report.add_argument(
        "--docs",
        action="store_true",
        help="also write the table into docs/benchmark.md (the sweep's generated section) "
        "and the plots into docs/benchmark/",
    )
    report.add_argument("--docs-file", type=Path, default=DOCS_FILE, help=argparse.SUPPRESS)
    report.add_argument("--no-plots", action="store_true", help="skip the PNG curves")
    return p.parse_args(argv)


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


# -- profiles ----------------------------------------------------------------------------------


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


# -- run ---------------------------------------------------------------------------------------


def cmd_run(args: argparse.Namespace, argv: list[str] | None) -> int:
    from multicrane.benchmark.backends import make_backend

    sweep = sweep_from(args)
    if args.dry_run:
        return show_status(sweep, args.workers or os.cpu_count() or 1, plan=True)
    validate_configs(sweep)
    backend = make_backend(args.backend, args.workers, args.address)
    started = datetime.datetime.now()
    print(f"sweep {sweep.name}: {sweep.budget()}")

    def session(outcome) -> dict:
        return {
            "command": command_line(__file__, argv),
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
        outcome = run_sweep(sweep, backend)
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
        print(f"report: {same_selection('report', args)}")
    return 0


def same_selection(sub: str, args: argparse.Namespace) -> str:
    """The command ``sub`` for the same sweep (``report`` after ``run``)."""
    parts = ["python", "tools/benchmark.py", sub, "--profile", args.profile]
    for flag, value in (
        ("--configs", args.configs),
        ("--algos", args.algos),
        ("--seeds", args.seeds),
        ("--steps", args.steps),
        ("--eval-every", args.eval_every),
        ("--eval-episodes", args.eval_episodes),
        ("--out", args.out),
    ):
        if value is None:
            continue
        parts.append(flag)
        parts += [str(v) for v in value] if isinstance(value, list) else [str(value)]
    return shlex.join(parts)


# -- status ------------------------------------------------------------------------------------


def show_status(sweep: Sweep, workers: int, plan: bool = False) -> int:
    states = sweep_states(sweep)
    counts = count_states(states.values())
    print(f"{sweep.out} ({sweep.name}: {sweep.budget()})")
    print(f"{len(states)} runs: " + ", ".join(f"{counts[k]} {k}" for k in STATES if counts[k]))
    width = max(len(a) for a in sweep.algos) + 2
    print("config  " + "".join(f"{a:>{max(width, 12)}}" for a in sweep.algos))
    for config in sweep.configs:
        cells = []
        for algo in sweep.algos:
            mine = [st for spec, st in states.items() if (spec.config, spec.algo) == (config, algo)]
            done = sum(st.kind == DONE for st in mine)
            text = f"{done}/{len(mine)}"
            other = sum(st.kind not in (DONE, PENDING) for st in mine)
            if other:
                text += f" +{other}"
            cells.append(f"{text:>{max(width, 12)}}")
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


# -- report ------------------------------------------------------------------------------------


BEGIN = "<!-- benchmark:{name}:begin"
END = "<!-- benchmark:{name}:end -->"


def session_labels(sweep: Sweep) -> dict[str, str]:
    sessions = read_manifest(sweep.out).get("sessions") or []
    sessions = [s for s in sessions if isinstance(s, dict)]
    labels: dict[str, str] = {}
    if not sessions:
        return labels
    last = sessions[-1]
    command = f"`{last.get('command', '?')}`"
    if len(sessions) > 1:
        command += f" ({len(sessions)} sessions, this was the last)"
    labels["run_command"] = command
    labels["machine"] = str(last.get("machine", ""))
    first, end = sessions[0].get("started", ""), last.get("finished", "")
    wall = 0.0
    for s in sessions:
        try:
            a = datetime.datetime.fromisoformat(s["started"])
            b = datetime.datetime.fromisoformat(s["finished"])
            wall += (b - a).total_seconds()
        except (KeyError, TypeError, ValueError):
            pass
    labels["date"] = f"runs {first} .. {end}"
    labels["wall"] = (
        f"{format_duration(wall)} wall time with {last.get('workers', '?')} "
        f"{last.get('backend', '')} workers"
    )
    return labels


def cmd_report(args: argparse.Namespace, argv: list[str] | None) -> int:
    sweep = sweep_from(args)
    if not sweep.out.is_dir():
        print(f"error: {sweep.out}: no such sweep directory (run it first)", file=sys.stderr)
        return 2
    results, problems = aggregate.collect(sweep)
    cells = aggregate.make_cells(sweep, results)
    labels = session_labels(sweep)
    labels["report_command"] = f"`{command_line(__file__, argv)}`"
    labels["date"] = f"report {datetime.date.today().isoformat()}" + (
        f"; {labels['date']}" if labels.get("date") else ""
    )
    labels.setdefault("machine", machine())
    compute = aggregate.compute_label(results)
    labels["wall"] = "; ".join(x for x in (labels.get("wall"), compute) if x)
    labels["versions"] = aggregate.versions_label(results)

    report_path = sweep.out / "report.md"
    targets = [(report_path, sweep.out / "plots", "#")]
    if args.docs:
        targets.append((args.docs_file, args.docs_file.parent / "benchmark", "###"))
    for page, plot_dir, heading in targets:
        plots = []
        if not args.no_plots:
            plots = make_plots(sweep, results, plot_dir)
        links = [os.path.relpath(p, page.parent) for p in plots]
        text = aggregate.markdown(sweep, cells, labels, links, problems, heading=heading)
        if page == report_path:
            write_atomic(page, text)
        else:
            fill_section(page, sweep.name, text)
        print(f"wrote {page}" + (f" and {len(plots)} plot(s) in {plot_dir}" if plots else ""))
    aggregate.write_summary(sweep.out / "summary.json", sweep, cells)
    print(f"wrote {sweep.out / 'summary.json'}")
    finished = sum(c.n for c in cells)
    total = sum(len(c.seeds) for c in cells)
    if finished < total:
        print(f"note: {total - finished} of {total} runs have no result yet (shown as missing)")
    return 0


def make_plots(sweep: Sweep, results, plot_dir: Path) -> list[Path]:
    try:
        from multicrane.benchmark.plots import import_matplotlib, write_plots

        import_matplotlib()
    except RuntimeError as exc:
        print(f"no plots: {exc}", file=sys.stderr)
        return []
    return write_plots(sweep, results, plot_dir, sweep.name)


def fill_section(path: Path, name: str, text: str) -> None:
    """Replace the sweep's generated section of ``path`` (between its begin and end
    markers) with ``text``; append the section when the file has none."""
    begin = BEGIN.format(name=name)
    end = END.format(name=name)
    block = (
        f"{begin} (generated by tools/benchmark.py report --docs; edits here are lost) -->\n"
        f"{text.rstrip()}\n{end}"
    )
    old = path.read_text() if path.exists() else ""
    pattern = re.compile(re.escape(begin) + r".*?" + re.escape(end), re.DOTALL)
    if pattern.search(old):
        new = pattern.sub(lambda _m: block, old, count=1)
    else:
        new = old.rstrip() + ("\n\n" if old.strip() else "") + block + "\n"
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, new)


# -- main --------------------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if hasattr(sys.stdout, "reconfigure"):
        sys.stdout.reconfigure(line_buffering=True)  # progress lines reach a log file at once
    try:
        if args.command == "profiles":
            return cmd_profiles(args)
        if args.command == "run":
            return cmd_run(args, argv)
        if args.command == "status":
            return cmd_status(args)
        return cmd_report(args, argv)
    except (SweepError, RuntimeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
