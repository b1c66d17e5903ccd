"""``multicrane replay``: 3D replays in the rerun viewer (live, record, replay, bench)."""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

from multicrane.cli.common import add_decisions_arg, error, formatter, run_decisions

DESCRIPTION = """3D replays of episodes with rerun (needs the 'replay' extra: rerun-sdk 0.41).

    multicrane replay live --scenario hall-4c --policy prioritized --spawn
    multicrane replay live --scenario hall-4c --connect rerun+http://127.0.0.1:9876/proxy
    multicrane replay record --scenario hall-4c --cranes 4 --policy prioritized \\
        --seed 0 --rrd hall.rrd --record hall.json.gz
    multicrane replay replay hall.json.gz --rrd again.rrd      # or --spawn / --connect
    multicrane replay bench --scenario hall-4c --policy random --steps 1000

live streams an episode step by step while it runs; record runs one and saves an .rrd file
and/or an episode record (JSON, gzip for .gz); replay re-simulates a saved record into a
viewer or a file, checking every step's events and the recorded end (return, steps, success,
final states); it refuses a record whose scenario changed or whose re-simulation differs
(status 2, naming each field: recorded vs re-simulated) and a file that cannot be read or
was changed after it was written (checksum; status 1); bench times an episode with and
without recording it to a file.

--spawn starts the viewer on PATH, else the one beside the running Python (.venv/bin/rerun).
With none, no display, or nothing listening at --connect's URL, the command says so in one
line (status 2); --rrd files work headless (open them later with `rerun FILE.rrd`), and
`rerun --serve-web` shows a stream in a browser.
"""
PLAY_STATES = ["paused", "playing", "following"]


def _episode_args(p: argparse.ArgumentParser, policy: str = "prioritized") -> None:
    p.add_argument("--scenario", default="hall-4c", help="shipped name or path to a .toml file")
    p.add_argument("--cranes", type=int, default=None, help="default: the scenario's")
    p.add_argument("--policy", default=policy,
                   help="prioritized, greedy, random, or a training run directory")  # fmt: skip
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--auto", action="store_true", help="automatic mode (random/greedy only)")
    p.add_argument("--max-steps", type=int, default=None, help="default: the scenario's limit")
    add_decisions_arg(p)


def _viewer_args(p: argparse.ArgumentParser) -> None:
    g = p.add_mutually_exclusive_group()
    g.add_argument("--spawn", action="store_true", help="start a viewer and stream to it")
    g.add_argument("--connect", metavar="URL", nargs="?", const="", default=None,
                   help="stream to a running viewer (default URL: the local one)")  # fmt: skip
    p.add_argument("--play-state", choices=PLAY_STATES, default=None,
                   help="initial state of the viewer's time panel")  # fmt: skip


def register(sub) -> None:
    top = sub.add_parser("replay", help="3D replays in rerun (needs the 'replay' extra)",
                         description=DESCRIPTION, **formatter())  # fmt: skip
    modes = top.add_subparsers(dest="mode", metavar="MODE", required=True)
    live = modes.add_parser("live", help="stream an episode to a viewer while it runs")
    _episode_args(live)
    _viewer_args(live)
    live.add_argument("--record", type=Path, help="also save the episode record here")
    live.set_defaults(func=cmd_live)
    rec = modes.add_parser("record", help="run an episode, save .rrd and/or an episode record")
    _episode_args(rec)
    rec.add_argument("--rrd", type=Path, help="write the 3D replay here (.rrd)")
    rec.add_argument("--record", type=Path, help="write the episode record (.json, .json.gz)")
    rec.add_argument("--play-state", choices=PLAY_STATES, default=None)
    rec.set_defaults(func=cmd_record)
    rep = modes.add_parser("replay", help="replay a saved episode record")
    rep.add_argument("record", type=Path, help="an episode record (.json or .json.gz)")
    rep.add_argument("--rrd", type=Path, help="write the replay here instead of a viewer")
    _viewer_args(rep)
    rep.set_defaults(func=cmd_replay)
    bench_p = modes.add_parser("bench", help="steps/s with and without recording to a file")
    _episode_args(bench_p, policy="random")
    bench_p.add_argument("--steps", type=int, default=1000, help="episode length (max steps)")
    bench_p.add_argument("--repeats", type=int, default=3)
    bench_p.set_defaults(func=cmd_bench)


def _guarded(command):
    """Run ``command(args)``, turning the library's refusals into ``error: ...`` and status 2."""

    def run(args: argparse.Namespace) -> int:
        import multicrane
        from multicrane.render.viewers import NoViewer
        from multicrane.replay.record import RecordError
        from policies import PolicyError

        try:
            return command(args)
        except (multicrane.ScenarioError, RecordError, PolicyError, ValueError, NoViewer) as exc:
            return error(exc)

    run.__doc__ = command.__doc__
    return run


def _episode(args: argparse.Namespace):
    """(env, policy) of the command's episode: the policy is made once (a run directory's
    model loads once), and the environment plays at its training decision level unless
    ``--decisions`` says otherwise."""
    import multicrane
    import policies

    make_policy = policies.factory(args.policy, paper=False)
    max_steps = getattr(args, "steps", None) or args.max_steps
    env = multicrane.parallel_env(
        args.scenario, n_cranes=args.cranes, auto=args.auto, max_steps=max_steps,
        decisions=run_decisions(args.decisions, [make_policy]),
    )  # fmt: skip
    return env, make_policy(env, args.seed)


def _stream(args: argparse.Namespace, name: str, scenario):
    """A stream connected to the viewer that ``--spawn`` or ``--connect`` names."""
    from multicrane.replay import viewer

    rec = viewer.new_recording(name)
    return viewer.connect(rec, args.connect or None, args.spawn, scenario, args.play_state)


def _summary(record) -> str:
    m = record.metrics
    ret = f"{m['return']:.2f}" if "return" in m else "?"
    done = {True: "success", False: "not finished"}.get(m.get("success"), "success ?")
    return (
        f"{record.scenario} ({record.n_cranes} cranes, {record.policy or 'policy ?'}, seed "
        f"{record.seed}): return {ret}, {m.get('steps', '?')} steps, {done}"
    )


@_guarded
def cmd_live(args: argparse.Namespace) -> int:
    from multicrane.replay import viewer

    if not (args.spawn or args.connect is not None):
        args.spawn = True
    env, policy = _episode(args)
    rec = _stream(args, f"{env.scenario.name} live", env.scenario)
    record = viewer.run_live(env, policy, args.seed, rec, policy_name=args.policy)
    rec.flush()
    print(_summary(record))
    if args.record:
        record.save(args.record)
        print(f"episode record: {args.record}")
    return 0


@_guarded
def cmd_record(args: argparse.Namespace) -> int:
    from multicrane.replay.record import record_episode

    if not (args.rrd or args.record):
        return error("give --rrd and/or --record")
    env, policy = _episode(args)
    if args.rrd:
        from multicrane.replay import viewer

        record = viewer.record_and_save(env, policy, args.seed, args.rrd, args.policy,
                                        play_state=args.play_state)  # fmt: skip
        print(f"replay: {args.rrd}")
    else:
        record = record_episode(env, policy, args.seed, args.policy)
    if args.record:
        record.save(args.record)
        print(f"episode record: {args.record}")
    print(_summary(record))
    return 0


@_guarded
def cmd_replay(args: argparse.Namespace) -> int:
    from multicrane.replay import viewer
    from multicrane.replay.record import EpisodeRecord, RecordError

    try:
        record = EpisodeRecord.load(args.record)
    except RecordError as exc:  # unreadable, changed or malformed: one line, status 1
        return error(exc, status=1)
    if args.rrd:
        viewer.record_to_rrd(record, args.rrd, play_state=args.play_state)
        print(f"replay: {args.rrd}")
    else:
        if not (args.spawn or args.connect is not None):
            args.spawn = True
        rec = _stream(args, viewer._name(record), record.load_scenario())
        viewer.send_record(record, rec)
        rec.flush()
    print(_summary(record))
    return 0


def bench(
    scenario: str = "hall-4c",
    cranes: int | None = None,
    policy: str = "random",
    steps: int = 1000,
    seed: int = 0,
    repeats: int = 3,
    auto: bool = False,
) -> dict:
    """Time ``repeats`` episodes of at most ``steps`` steps without and with recording to an
    .rrd file (collecting as it runs, then ``send_columns``) plus the episode record."""
    import multicrane
    import policies
    from multicrane.replay import viewer
    from multicrane.replay.record import record_episode

    env = multicrane.parallel_env(scenario, n_cranes=cranes, auto=auto, max_steps=steps)
    make_policy = policies.factory(policy, paper=False)
    plain, recorded, n_steps = [], [], 0
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(repeats):
            t0 = time.perf_counter()
            rec = record_episode(env, make_policy(env, seed + i), seed + i, policy)
            plain.append(time.perf_counter() - t0)
            n_steps = rec.steps
            t0 = time.perf_counter()
            rec2 = viewer.record_and_save(
                env, make_policy(env, seed + i), seed + i, Path(tmp) / "e.rrd", policy
            )
            rec2.save(Path(tmp) / "e.json.gz")
            recorded.append(time.perf_counter() - t0)
            if rec2.actions != rec.actions:
                raise RuntimeError("recording changed the episode")
    a, b = statistics.median(plain), statistics.median(recorded)
    return {
        "scenario": scenario,
        "cranes": env.sim.n_cranes,
        "policy": policy,
        "steps": n_steps,
        "plain_steps_per_s": n_steps / a,
        "recorded_steps_per_s": n_steps / b,
        "ratio": b / a,
    }


@_guarded
def cmd_bench(args: argparse.Namespace) -> int:
    r = bench(args.scenario, args.cranes, args.policy, args.steps, args.seed, args.repeats,
              args.auto)  # fmt: skip
    print(
        f"{r['scenario']}, {r['cranes']} cranes, {r['policy']} policy, {r['steps']} steps "
        f"(median of {args.repeats}):\n"
        f"  episode only:                 {r['plain_steps_per_s']:8.0f} steps/s\n"
        f"  episode + .rrd + record file: {r['recorded_steps_per_s']:8.0f} steps/s\n"
        f"  time ratio: {r['ratio']:.2f}x (target: at most 2x)",
        file=sys.stdout,
    )
    return 0
