"""``multicrane suite``: build, bound, evaluate, verify and rank on multicrane-bench."""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from multicrane.cli.common import error, formatter

DESCRIPTION = """multicrane-bench: a frozen instance library (scenarios/suite/VERSION), proven
lower bounds, best-known plans and a verified leaderboard (docs/suite.md).

    multicrane suite evaluate v1 --track small --policy prioritized --out small-prio.json
    multicrane suite evaluate v1 --track small --policy lookahead      # task decisions
    multicrane suite evaluate v1 --track small --policy runs/RUN       # a training run
    multicrane suite evaluate v1 --track small --policy runs/RUN --name ppo-zero-shot
    multicrane suite verify small-prio.json
    multicrane suite page                     # docs/suite-leaderboard.md and best.json
    multicrane suite build v1 --check         # the shipped files are rebuilt bit for bit
    multicrane suite bounds v1 --track small  # CP-SAT bounds into bounds.json (one worker)
    multicrane suite improve v1 --track small --seconds 60   # LNS on the best-known plans

VERSION is a shipped version (v1) or a folder holding a manifest.toml.
"""
TASK_ONLY = ("lookahead",)  # planners that decide at the task level only


def register(sub) -> None:
    p = sub.add_parser("suite", help="the benchmark suite: evaluate, verify, leaderboard",
                       description=DESCRIPTION, **formatter())  # fmt: skip
    cmds = p.add_subparsers(dest="suite_command", metavar="ACTION", required=True)
    e = cmds.add_parser("evaluate", help="play a policy on every instance of a track")
    e.add_argument("version", help="v1, or a folder with a manifest.toml")
    e.add_argument("--track", required=True, help="small, small-reach, small-events, ...")
    e.add_argument("--policy", required=True,
                   help="a planner, a training run directory; NAME:KEY=VALUE,...")  # fmt: skip
    e.add_argument("--decisions", choices=("motion", "task"), default=None,
                   help="default: task for lookahead, a run's own, else motion")  # fmt: skip
    e.add_argument("--name", help="the entry's policy name in the results (default: the "
                   "planner's name, or 'ALGO (RUN)' for a training run)")  # fmt: skip
    e.add_argument("--out", type=Path, help="results file (default: suite-VERSION-TRACK-POLICY"
                   ".json here; .gz: compressed)")  # fmt: skip
    e.set_defaults(func=evaluate)
    v = cmds.add_parser("verify", help="re-simulate every record of results files")
    v.add_argument("results", nargs="+", type=Path)
    v.add_argument("--suite", help="the version or folder (default: the results' version)")
    v.set_defaults(func=verify)
    g = cmds.add_parser("page", help="write the leaderboard from the verified results")
    g.add_argument("version", nargs="?", default="v1")
    g.add_argument("--out", type=Path, default=Path("docs/suite-leaderboard.md"))
    g.set_defaults(func=page)
    b = cmds.add_parser("build", help="write a version's scenario files and manifest")
    b.add_argument("version", nargs="?", default="v1")
    b.add_argument("--out", type=Path, help="folder (default: the shipped one)")
    b.add_argument("--check", action="store_true",
                   help="rebuild in a temporary folder, compare with the shipped "
                   "files")  # fmt: skip
    b.set_defaults(func=build)
    n = cmds.add_parser("bounds", help="compute the instances' CP-SAT lower bounds")
    n.add_argument("version", nargs="?", default="v1")
    n.add_argument("--track", nargs="+", help="only these tracks (default: all)")
    n.add_argument("--time-limit", type=float, help="seconds per bound (default: the size's)")
    n.add_argument("--workers", type=int, default=1)
    n.set_defaults(func=bounds)
    i = cmds.add_parser("improve", help="improve the best-known plans by large-neighbourhood "
                        "search")  # fmt: skip
    i.add_argument("version", help="v1, or a folder with a manifest.toml")
    i.add_argument("--track", required=True, help="small, small-reach, small-events, ...")
    i.add_argument("--seconds", type=float, default=60.0, help="search budget per instance")
    i.add_argument("--instances", nargs="+", help="only these instance ids")
    i.add_argument("--seed", type=int, default=0, help="the search's random seed")
    i.add_argument("--from-relaxation", type=float, default=0.0, metavar="SECONDS",
                   help="also play the bound relaxation's schedule (CP-SAT, SECONDS) and start "
                   "from it when shorter")  # fmt: skip
    i.add_argument("--out", type=Path, help="results file (default: suite-VERSION-TRACK-lns"
                   ".json here; .gz: compressed)")  # fmt: skip
    i.set_defaults(func=improve)


def _log(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def _resolve(name: str, decisions: str | None):
    """The policy factory, its label, decision level and training block (a training run's,
    else None) for a name or a run directory."""
    import policies
    from multicrane.cli.common import trained_decisions
    from multicrane.suite.play import training_block

    make = policies.factory(name, paper=False)
    if decisions is None:
        decisions = "task" if make.name in TASK_ONLY else trained_decisions(make)
    training = None if make.config is None else training_block(name, make.config.to_dict())
    return make, make.label, decisions, training


def evaluate(args: argparse.Namespace) -> int:
    from multicrane.suite.manifest import read_manifest
    from multicrane.suite.page import read_best
    from multicrane.suite.play import play_track

    try:
        manifest = read_manifest(args.version)
        manifest.track(args.track)
        make, label, decisions, training = _resolve(args.policy, args.decisions)
        label = args.name or label
        results = play_track(
            manifest, args.track, make, label, decisions, read_best(manifest),
            log=lambda e: _log(f"{e['id']}: makespan {e['makespan']} ({e['seconds']:.1f} s)"),
            training=training,
        )  # fmt: skip
    except ValueError as exc:  # SuiteError, policies.PolicyError, a policy refusing a site
        return error(exc)
    named = args.name or Path(args.policy).name
    slug = "".join(c if c.isalnum() or c in "-_" else "-" for c in named)
    out = args.out or Path(f"suite-{manifest.version}-{args.track}-{slug}.json")
    return _write_and_show(out, results, f"{label} ({decisions}) on {manifest.version} track "
                           f"{args.track}")  # fmt: skip


def verify(args: argparse.Namespace) -> int:
    from multicrane.suite.manifest import SuiteError, read_manifest
    from multicrane.suite.results import read_results
    from multicrane.suite.verify import verify as check

    for path in args.results:
        try:
            results = read_results(path)
            check(results, read_manifest(args.suite or str(results.get("version"))))
        except SuiteError as exc:
            return error(f"{path}: refused: {exc}", status=1)
        n = len(results["instances"])
        print(f"{path}: verified ({n} instances of track {results['track']}, "
              f"{results['policy']})")  # fmt: skip
    return 0


def page(args: argparse.Namespace) -> int:
    import policies
    from multicrane.files import write_atomic
    from multicrane.reports.provenance import command_line
    from multicrane.suite.bounds import read_bounds
    from multicrane.suite.manifest import SuiteError, read_manifest
    from multicrane.suite.page import best_known, collect, leaderboard, results_files, write_best

    try:
        manifest = read_manifest(args.version)
        collected = collect(manifest, results_files(manifest))
    except SuiteError as exc:
        return error(f"refused: {exc}", status=1)
    best = best_known(collected, manifest.folder)
    print(f"wrote {write_best(manifest, best)}", file=sys.stderr)
    text = leaderboard(manifest, collected, best, read_bounds(manifest),
                       first=policies.NAMES, command=command_line(args.argv))  # fmt: skip
    args.out.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(args.out, text)
    print(f"wrote {args.out} ({len(collected)} results files)")
    return 0


def build(args: argparse.Namespace) -> int:
    from multicrane.suite.build import build as write_version
    from multicrane.suite.manifest import suite_dir

    try:
        if not args.check:
            print(f"wrote {write_version(args.version, args.out or suite_dir(args.version), _log)}")
            return 0
        shipped = args.out or suite_dir(args.version)
        with tempfile.TemporaryDirectory() as tmp:
            write_version(args.version, Path(tmp), _log)
            made = sorted(p.relative_to(tmp) for p in Path(tmp).rglob("*") if p.is_file())
            differ = [str(p) for p in made
                      if (Path(tmp) / p).read_bytes() != _bytes(shipped / p)]  # fmt: skip
    except ValueError as exc:
        return error(exc)
    if differ:
        return error(f"{shipped}: differs from a rebuild: {', '.join(differ)}", status=1)
    print(f"{shipped}: {len(made)} files, identical to a rebuild")
    return 0


def _bytes(path: Path) -> bytes | None:
    return path.read_bytes() if path.is_file() else None


def bounds(args: argparse.Namespace) -> int:
    from multicrane.suite.bounds import compute_bounds
    from multicrane.suite.manifest import SuiteError, read_manifest

    try:
        manifest = read_manifest(args.version)
        ids = None
        if args.track:
            ids = [i.id for t in args.track for i in manifest.track(t)]
        compute_bounds(manifest, ids, args.time_limit, args.workers, log=print)
    except (SuiteError, ValueError) as exc:
        return error(exc)
    return 0


def improve(args: argparse.Namespace) -> int:
    from multicrane.suite.lns import LABEL, improve_track
    from multicrane.suite.manifest import SuiteError, read_manifest

    if not args.seconds > 0:
        return error(f"--seconds must be positive, got {args.seconds}")
    try:
        manifest = read_manifest(args.version)
        known = {i.id for i in manifest.track(args.track)}
        unknown = sorted(set(args.instances or ()) - known)
        if unknown:
            raise SuiteError(f"not in track {args.track}: {', '.join(unknown)}")
        results = improve_track(manifest, args.track, args.seconds, args.instances, args.seed,
                                log=_log, relaxation_seconds=args.from_relaxation)  # fmt: skip
    except SuiteError as exc:
        return error(exc)
    out = args.out or Path(f"suite-{manifest.version}-{args.track}-{LABEL}.json")
    return _write_and_show(out, results, f"{LABEL} on {manifest.version} track {args.track} "
                           f"({args.seconds:g} s per instance)")  # fmt: skip


def _write_and_show(out: Path, results: dict, heading: str) -> int:
    """Write a results file and print its table under ``heading``."""
    from multicrane.suite.results import results_table, write_results

    write_results(out, results)
    print(f"{heading}:")
    print(results_table(results))
    print(f"wrote {out}")
    return 0
