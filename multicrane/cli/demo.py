"""``multicrane demo``: the main job: train shared PPO for cranes, compare it, save a replay."""

from __future__ import annotations

import argparse
from pathlib import Path

from multicrane.cli.common import formatter

DESCRIPTION = """The main job (bash tools/demo.sh runs it): train parameter-sharing PPO for
the cranes of a scenario, compare it with the planners, and save a replay. Needs the 'train'
and 'replay' extras.

    multicrane demo                                   # the defaults below, ~10 minutes
    multicrane demo --scenario e1s1 --cranes 2 --steps 400000

1. multicrane train: MaskablePPO with one policy shared by every crane, for a short budget
   (resumes or reuses a finished run in --out).
2. multicrane evaluate: the trained policy beside the prioritized planner, greedy and random
   cranes, on the same episodes.
3. multicrane replay record: one episode of the trained policy as a rerun replay (.rrd, open
   it with rerun FILE) and an episode record (.json.gz).
"""


def register(sub) -> None:
    p = sub.add_parser("demo", help="the main job: train, compare, replay",
                       description=DESCRIPTION, **formatter())  # fmt: skip
    p.add_argument("--scenario", default="e2s2")
    p.add_argument("--cranes", type=int, default=2)
    p.add_argument("--steps", type=int, default=1_000_000, help="crane decisions")
    p.add_argument("--algo", default="maskable_ppo", choices=("ppo", "maskable_ppo"))
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--episodes", type=int, default=20, help="evaluation episodes")
    p.add_argument("--out", type=Path, default=Path("runs/demo"))
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from multicrane.cli import main

    run_dir = args.out / f"{args.scenario}-{args.cranes}c-{args.algo}-s{args.seed}"
    where = ["--scenario", args.scenario, "--cranes", str(args.cranes)]
    print(f"== 1. train {args.algo} (shared by {args.cranes} cranes) on {args.scenario}")
    code = main(
        ["train", *where, "--algo", args.algo, "--steps", str(args.steps), "--seed",
         str(args.seed), "--eval-every", str(max(args.steps // 10, 1)), "--out", str(run_dir)]
    )  # fmt: skip
    if code:
        return code
    print(f"\n== 2. evaluate ({args.episodes} episodes, the same seeds for every policy)")
    code = main(
        ["evaluate", *where, "--policy", str(run_dir), "prioritized", "greedy", "random",
         "--episodes", str(args.episodes), "--json", str(run_dir / "evaluation.json")]
    )  # fmt: skip
    if code:
        return code
    print("\n== 3. replay one episode of the trained policy")
    code = main(
        ["replay", "record", *where, "--policy", str(run_dir), "--seed", "1000000",
         "--rrd", str(run_dir / "replay.rrd"), "--record", str(run_dir / "episode.json.gz")]
    )  # fmt: skip
    if code:
        return code
    print(
        f"\nwatch it: .venv/bin/rerun {run_dir / 'replay.rrd'}    "
        f"learning curves: .venv/bin/tensorboard --logdir {run_dir / 'tb'}"
    )
    return 0
