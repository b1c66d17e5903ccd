"""3D replays of episodes with rerun (needs the ``replay`` extra: rerun-sdk 0.41).

    python tools/replay.py live --scenario hall-4c --policy prioritized --spawn
    python tools/replay.py live --scenario hall-4c --connect rerun+http://127.0.0.1:9876/proxy
    python tools/replay.py record --scenario hall-4c --cranes 4 --policy prioritized \\
        --seed 0 --rrd hall.rrd --record hall.json.gz
    python tools/replay.py replay hall.json.gz --rrd again.rrd      # or --spawn / --connect
    python tools/replay.py bench --scenario hall-4c --policy random --steps 1000

``live`` streams an episode step by step while it runs; ``record`` runs one and saves an
.rrd file and/or an episode record (JSON, gzip for .gz); ``replay`` re-simulates a saved
record (refusing one whose scenario changed) into a viewer or a file; ``bench`` times an
episode with and without recording it to a file.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import multicrane  # noqa: E402
import policies  # noqa: E402
from multicrane.record import EpisodeRecord, RecordError, record_episode  # noqa: E402

PLAY_STATES = ["paused", "playing", "following"]


def make_policy(spec: str, env, seed: int):
    """A named policy, or a trained model's run directory (``policies.make``)."""
    return policies.make(spec, env, seed)


def _episode_args(p: argparse.ArgumentParser, policy: str = "prioritized") -> None:
    p.add_argument("--scenario", default="hall-4c", help="shipped name or path to a .toml file")
    p.add_argument("--cranes", type=int, default=None, help="default: the scenario's")
    p.add_argument("--policy", default=policy,
                   help=f"{', '.join(policies.names(False))}, or a training run")  # fmt: skip
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--auto", action="store_true", help="automatic mode (random/greedy only)")
    p.add_argument("--max-steps", type=int, default=None, help="default: the scenario's limit")


def _viewer_args(p: argparse.ArgumentParser) -> None:
    g = p.add_mutually_exclusive_group()
    g.add_argument("--spawn", action="store_true", help="start a viewer and stream to it")
    g.add_argument("--connect", metavar="URL", nargs="?", const="", default=None,
                   help="stream to a running viewer (default URL: the local one)")  # fmt: skip
    p.add_argument("--play-state", choices=PLAY_STATES, default=None,
                   help="initial state of the viewer's time panel")  # fmt: skip


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    sub = p.add_subparsers(dest="command", required=True)
    live = sub.add_parser("live", help="stream an episode to a viewer while it runs")
    _episode_args(live)
    _viewer_args(live)
    live.add_argument("--record", type=Path, help="also save the episode record here")
    rec = sub.add_parser("record", help="run an episode, save .rrd and/or an episode record")
    _episode_args(rec)
    rec.add_argument("--rrd", type=Path, help="write the 3D replay here (.rrd)")
    rec.add_argument("--record", type=Path, help="write the episode record (.json, .json.gz)")
    rec.add_argument("--play-state", choices=PLAY_STATES, default=None)
    rep = sub.add_parser("replay", help="replay a saved episode record")
    rep.add_argument("record", type=Path, help="an episode record (.json or .json.gz)")
    rep.add_argument("--rrd", type=Path, help="write the replay here instead of a viewer")
    _viewer_args(rep)
    bench = sub.add_parser("bench", help="steps/s with and without recording to a file")
    _episode_args(bench, policy="random")
    bench.add_argument("--steps", type=int, default=1000, help="episode length (max steps)")
    bench.add_argument("--repeats", type=int, default=3)
    return p.parse_args(argv)


def _make_env(args: argparse.Namespace):
    max_steps = getattr(args, "steps", None) or args.max_steps
    return multicrane.parallel_env(
        args.scenario, n_cranes=args.cranes, auto=args.auto, max_steps=max_steps
    )


def _stream(args: argparse.Namespace, name: str, scenario):
    from multicrane import viewer

    rec = viewer.new_recording(name)
    if args.spawn:
        rec.spawn(default_blueprint=viewer.blueprint(scenario, args.play_state))
    else:
        rec.connect_grpc(args.connect or None,
                         default_blueprint=viewer.blueprint(scenario, args.play_state))  # fmt: skip
    return rec


def _summary(record: EpisodeRecord) -> str:
    m = record.metrics
    return (
        f"{record.scenario} ({record.n_cranes} cranes, {record.policy or 'policy ?'}, seed "
        f"{record.seed}): return {m['return']:.2f}, {m['steps']} steps, "
        f"{'success' if m['success'] else 'not finished'}"
    )


def cmd_live(args: argparse.Namespace) -> int:
    from multicrane import viewer

    if not (args.spawn or args.connect is not None):
        args.spawn = True
    env = _make_env(args)
    rec = _stream(args, f"{env.scenario.name} live", env.scenario)
    record = viewer.run_live(env, make_policy(args.policy, env, args.seed), args.seed, rec,
                             policy_name=args.policy)  # fmt: skip
    rec.flush()
    print(_summary(record))
    if args.record:
        record.save(args.record)
        print(f"episode record: {args.record}")
    return 0


def cmd_record(args: argparse.Namespace) -> int:
    from multicrane import viewer

    if not (args.rrd or args.record):
        print("error: give --rrd and/or --record", file=sys.stderr)
        return 2
    env = _make_env(args)
    policy = make_policy(args.policy, env, args.seed)
    if args.rrd:
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


def cmd_replay(args: argparse.Namespace) -> int:
    from multicrane import viewer

    try:
        record = EpisodeRecord.load(args.record)
        if args.rrd:
            viewer.record_to_rrd(record, args.rrd, play_state=args.play_state)
            print(f"replay: {args.rrd}")
        else:
            if not (args.spawn or args.connect is not None):
                args.spawn = True
            scenario = record.load_scenario()
            rec = _stream(args, viewer._name(record), scenario)
            viewer.send_record(record, rec)
            rec.flush()
    except RecordError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
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
    from multicrane import viewer

    env = multicrane.parallel_env(scenario, n_cranes=cranes, auto=auto, max_steps=steps)
    plain, recorded, n_steps = [], [], 0
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(repeats):
            t0 = time.perf_counter()
            rec = record_episode(env, make_policy(policy, env, seed + i), seed + i, policy)
            plain.append(time.perf_counter() - t0)
            n_steps = rec.steps
            t0 = time.perf_counter()
            rec2 = viewer.record_and_save(
                env, make_policy(policy, env, seed + i), seed + i, Path(tmp) / "e.rrd", policy
            )
            rec2.save(Path(tmp) / "e.json.gz")
            recorded.append(time.perf_counter() - t0)
            assert rec2.actions == rec.actions
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


def cmd_bench(args: argparse.Namespace) -> int:
    r = bench(args.scenario, args.cranes, args.policy, args.steps, args.seed, args.repeats,
              args.auto)  # fmt: skip
    print(
        f"{r['scenario']}, {r['cranes']} cranes, {r['policy']} policy, {r['steps']} steps "
        f"(median of {args.repeats}):\n"
        f"  episode only:                 {r['plain_steps_per_s']:8.0f} steps/s\n"
        f"  episode + .rrd + record file: {r['recorded_steps_per_s']:8.0f} steps/s\n"
        f"  time ratio: {r['ratio']:.2f}x (target: at most 2x)"
    )
    return 0


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        return {"live": cmd_live, "record": cmd_record, "replay": cmd_replay,
                "bench": cmd_bench}[args.command](args)  # fmt: skip
    except (multicrane.ScenarioError, RecordError, ValueError) as exc:  # PolicyError too
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except ImportError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 3


if __name__ == "__main__":
    sys.exit(main())
