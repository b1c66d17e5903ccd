"""``multicrane plan``: run any policy on any scenario and print its metrics; record it if asked."""

from __future__ import annotations

import argparse
from functools import partial
from pathlib import Path

from multicrane.cli import progress
from multicrane.cli.common import (
    add_decisions_arg,
    add_events_arg,
    counting,
    describe,
    error,
    formatter,
    make_env,
    needs_extra,
    run_decisions,
    run_events,
)
from multicrane.cli.gantt import lacks_matplotlib
from multicrane.envs.decision_modes import decision_mode

DESCRIPTION = """Run policies on a scenario and print what they achieve.

    multicrane plan hall-4c --cranes 4 --policy prioritized
    multicrane plan frame2-3c --policy prioritized greedy random --episodes 5
    multicrane plan e2s2 --policy greedy --render                # print the final site
    multicrane plan hall-4c --policy prioritized --record ep.json.gz --rrd ep.rrd
    multicrane plan hall-4c --policy prioritized --gantt ep.html  # or ep.png ('bench' extra)
    multicrane plan hall-4c --policy prioritized --video ep.mp4   # or ep.gif ('video' extra)
    multicrane plan set:test-small --policy prioritized greedy  # a held-out set: set means
    multicrane plan E2S2 --paper --policy optimal greedy         # single-agent paper mode
    multicrane plan hall-4c --policy replanning static-plan --events high --episodes 5

SCENARIO is a shipped scenario name or a .toml file (with --paper: a paper configuration,
E1S1 .. E4S4), or a scenario set: set:test-small, set:test-large or set:train:FIRST-END
(train seeds FIRST..END-1); a set prints one row per site and the set's means.
A policy is prioritized, greedy, random (optimal in paper mode) or a training
run directory (needs the 'train' extra). Episode i starts from reset(seed=--seed + i), the
same for every policy. Prints, per policy: mean return ± standard error, success rate,
makespan (joint steps to finish, finished episodes), steps, and in multi-agent mode crane
utilisation, blocked moves and planning time per joint step. --record writes the first
episode as an episode record (.json or .json.gz), --rrd as a rerun replay (the 'replay'
extra), --gantt as a Gantt chart of the cranes (.html: a page with the chart as inline
SVG; .png: a picture, the 'bench' extra); these need one policy, multi-agent mode. --video
writes the first episode's pictures (the rgb_array render, one frame per reset and step,
--fps per second) as an .mp4 or .gif (the 'video' extra), one policy, either mode.
--events none|low|high turns on site events (late deliveries, breakdowns, closed zones;
docs/uncertainty.md); without it the scenario's own [events] table applies, or the level a
run directory policy was trained with.
"""


def register(sub) -> None:
    p = sub.add_parser("plan", help="run a policy on a scenario and print its metrics",
                       description=DESCRIPTION, **formatter())  # fmt: skip
    p.add_argument("scenario", help="shipped name, .toml path, or (with --paper) E1S1 .. E4S4")
    p.add_argument("--paper", action="store_true", help="single-agent paper mode")
    p.add_argument("--cranes", type=int, default=None, help="default: the scenario's")
    p.add_argument(
        "--policy",
        nargs="+",
        default=["prioritized"],
        help="prioritized, greedy, random, lookahead, optimal (paper), or a run directory; "
        "options as NAME:KEY=VALUE,... (lookahead:candidates=20)",
    )
    add_decisions_arg(p)
    p.add_argument("--episodes", type=int, default=1)
    p.add_argument("--seed", type=int, default=0, help="first episode seed")
    p.add_argument("--auto", action="store_true", help="automatic claiming and assembly")
    p.add_argument("--max-steps", type=int, default=None, help="default: the scenario's limit")
    p.add_argument("--render", action="store_true", help="print the site after the last episode")
    p.add_argument("--record", type=Path, help="write the first episode's record here")
    p.add_argument("--rrd", type=Path, help="write the first episode's 3D replay here (.rrd)")
    p.add_argument("--gantt", type=Path,
                   help="write the first episode's Gantt chart here (.html or .png)")
    p.add_argument("--video", type=Path, help="write the first episode's video here (.mp4, .gif)")
    p.add_argument("--fps", type=float, default=4.0, help="frames per second of --video")
    add_events_arg(p)
    p.set_defaults(func=run)


def _num(x: float | None, spec: str) -> str:
    return "-" if x is None else format(x, spec)


def header(multi: bool, width: int = 24) -> str:
    """The table's head; ``width``: the policy column's (``label_width``)."""
    head = f"{'policy':<{width}} {'return':>18} {'success':>8} {'makespan':>9} {'steps':>8}"
    if multi:
        head += f" {'util.':>6} {'blocked':>8} {'ms/step':>8}"
    return head


def label_width(makers) -> int:
    """The policy column's width: 24, or the longest label (a name with its options)."""
    return max([24] + [len(make.label) for make in makers])


def line(label: str, s: dict, multi: bool, width: int = 24) -> str:
    """One policy's row, from the summary of its episodes
    (``multicrane.episodes.rollout.summarise``)."""
    text = (
        f"{label:<{width}} {s['return_mean']:>10.2f} ± {_num(s['return_sem'], '.2f'):<6}"
        f"{s['success_rate']:>8.0%} {_num(s.get('makespan_mean'), '.1f'):>9}"
        f" {s['steps_mean']:>8.1f}"
    )
    if multi:
        text += (
            f" {s['utilisation_mean']:>6.0%} {s['blocked_moves_mean']:>8.1f}"
            f" {s['plan_ms_per_step']:>8.2f}"
        )
    return text


def record(args: argparse.Namespace, env, name: str) -> None:
    """Run the first episode again, recording it (an episode record, a .rrd and/or a Gantt
    chart)."""
    import policies
    from multicrane.replay.record import record_episode
    from multicrane.replay.timeline import Timeline

    policy = policies.make(name, env, seed=args.seed)
    timeline = Timeline()
    if args.rrd:
        from multicrane.replay import viewer

        rec = viewer.record_and_save(env, policy, args.seed, args.rrd, name, [timeline])
        print(f"replay: {args.rrd}")
    else:
        rec = record_episode(env, policy, args.seed, name, listeners=[timeline])
    if args.record:
        rec.save(args.record)
        print(f"episode record: {args.record}")
    if args.gantt:
        from multicrane.reports.gantt import record_title, write_gantt

        write_gantt(timeline.intervals, args.gantt, env.scenario.ids, record_title(rec))
        print(f"gantt chart: {args.gantt}")


def video(args: argparse.Namespace, env, make) -> None:
    """Run the first episode again, writing its pictures to ``args.video``."""
    from multicrane.episodes.rollout import run_episode
    from multicrane.render.video import EpisodeVideo

    with EpisodeVideo(args.video, fps=args.fps) as frames:
        run_episode(env, make(env, args.seed), args.seed, on_reset=frames.on_reset,
                    on_step=frames.on_step)  # fmt: skip
    print(f"video: {args.video} ({frames.frames} frames)")


def run(args: argparse.Namespace) -> int:
    import multicrane
    import policies
    from multicrane.cli.set_runs import run_set
    from multicrane.episodes.rollout import evaluate
    from multicrane.replay.record import RecordError
    from multicrane.scenario.named_sets import is_set_ref

    if args.episodes < 1:
        return error("--episodes must be at least 1")
    if (args.record or args.rrd or args.gantt) and (args.paper or len(args.policy) != 1):
        return error("--record, --rrd and --gantt need one policy in multi-agent mode")
    if args.gantt and lacks_matplotlib(args.gantt):
        return needs_extra("plan", "bench")
    if args.video:
        from multicrane.render.video import require_video

        if len(args.policy) != 1 or args.fps <= 0:
            return error("--video needs one policy and a positive --fps")
        try:
            require_video(args.video)
        except ImportError:
            return needs_extra("plan", "video")
    try:
        if args.paper and args.events is not None:
            return error(f"--events {args.events} is a multi-agent option (not with --paper)")
        makers = [policies.factory(name, paper=args.paper) for name in args.policy]
        if not args.paper:
            args.events = run_events(args.events, makers)
            args.decisions = run_decisions(args.decisions, makers)
        elif args.decisions is not None and decision_mode(args.decisions).task_level:
            return error(f"--decisions {args.decisions} is a multi-agent option (not with "
                         "--paper)")
        if is_set_ref(args.scenario) and not args.paper:
            if args.record or args.rrd or args.gantt or args.render or args.video:
                return error("--record, --rrd, --gantt, --video and --render take one "
                             "scenario, not a set")
            width = label_width(makers)
            return run_set(args, makers, header(True, width), partial(line, width=width))
        if args.paper:
            env = make_env(args.scenario)
        else:
            options = {} if args.max_steps is None else {"max_steps": args.max_steps}
            env = make_env(None, args.scenario, args.cranes, args.auto, render_mode="ansi",
                           events=args.events, decisions=args.decisions, **options)  # fmt: skip
        multi = not args.paper
        seeds = list(range(args.seed, args.seed + args.episodes))
        print(describe(env))
        width = label_width(makers)
        print(header(multi, width))
        for make in makers:
            with progress.bar(len(seeds), make.label) as advance:
                _, summary = evaluate(env, make, seeds, counting(advance))
            print(line(make.label, summary, multi, width))
        if args.render and multi:
            print(env.render())
        if args.record or args.rrd or args.gantt:
            record(args, env, args.policy[0])
        if args.video:
            video(args, env, makers[0])
    except (policies.PolicyError, multicrane.ScenarioError, RecordError, ValueError) as exc:
        return error(exc)
    return 0
