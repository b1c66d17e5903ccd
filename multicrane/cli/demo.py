"""``multicrane demo``: the main job: train shared PPO for cranes, compare it, save a replay."""

from __future__ import annotations

import argparse
from pathlib import Path

from multicrane.cli.common import formatter
from multicrane.envs.decision_modes import DECISION_MODES, decision_mode

DESCRIPTION = """The main job (bash tools/demo.sh runs it): train one policy shared by every
crane of a site, compare it with the planners and the proven lower bound, and save a replay.
Needs the 'train' and 'replay' extras.

    multicrane demo                                   # hall-4c, 4 cranes, ~15 minutes
    multicrane demo --scenario frame2-3c
    multicrane demo --decisions motion --scenario e2s2 --cranes 2 --steps 1000000

1. multicrane train: one policy shared by every crane (resumes or reuses a finished run in
   --out). Task decisions (the default): the set policy (docs/training.md), which reads the
   site's components and cranes as sets, from random weights, with no demonstrations:
   MaskablePPO on the undiscounted makespan reward for --steps crane decisions (at most
   --minutes of training), keeping the best point on validation episodes.
   --decisions motion: the MLP deciding every move, MaskablePPO from scratch.
2. multicrane evaluate: the trained policy beside the prioritized and look-ahead planners,
   greedy and random cranes, on the same episodes; then multicrane seed-table: the same as
   one table, with the proven makespan lower bound of every episode (CP-SAT, --bound-time
   seconds each; 0: none).
3. multicrane replay record: one episode of the trained policy as a rerun replay (.rrd, open
   it with rerun FILE) and an episode record (.json.gz).
"""


def register(sub) -> None:
    p = sub.add_parser("demo", help="the main job: train, compare, replay",
                       description=DESCRIPTION, **formatter())  # fmt: skip
    p.add_argument("--scenario", default="hall-4c")
    p.add_argument("--cranes", type=int, default=4)
    p.add_argument("--decisions", default="task", choices=tuple(DECISION_MODES),
                   help="task: the set policy picks tasks; motion: an MLP picks moves")  # fmt: skip
    p.add_argument("--steps", type=int, default=None,
                   help="crane decisions of PPO (default: 1,000,000 task, 300,000 motion)")
    p.add_argument("--minutes", type=float, default=13.0,
                   help="task decisions: training stops after this wall time if the steps "
                   "take longer (default 13)")
    p.add_argument("--algo", default="maskable_ppo", choices=("ppo", "maskable_ppo"))
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--episodes", type=int, default=20, help="evaluation episodes")
    p.add_argument("--bound-time", type=float, default=5.0,
                   help="CP-SAT seconds per episode's lower bound (0: no bound)")  # fmt: skip
    p.add_argument("--out", type=Path, default=Path("runs/demo"))
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from multicrane.cli import main

    task = decision_mode(args.decisions).task_level
    kind = "set" if task else args.algo
    steps = args.steps or (1_000_000 if task else 300_000)
    run_dir = args.out / f"{args.scenario}-{args.cranes}c-{kind}-s{args.seed}"
    where = ["--scenario", args.scenario, "--cranes", str(args.cranes)]
    level = ["--decisions", args.decisions]
    what = "the set policy, task decisions" if task else f"{args.algo}, motion decisions"
    print(f"== 1. train {what} (one policy shared by {args.cranes} cranes) on {args.scenario}")
    recipe = ["--policy", "set", "--reward", "makespan", "--shaping", "0", "--set",
              "learning_rate=1e-3", "--keep-best", "--time-limit", str(60 * args.minutes)]
    code = main(
        ["train", *where, *level, *(recipe if task else []), "--algo", args.algo,
         "--steps", str(steps), "--seed", str(args.seed),
         "--eval-every", str(max(min(steps // 5, 40_960) if task else steps // 10, 1)),
         "--out", str(run_dir)]
    )  # fmt: skip
    if code:
        return code
    print(f"\n== 2. evaluate ({args.episodes} episodes, the same seeds for every policy)")
    code = main(
        ["evaluate", *where, *level, "--policy", str(run_dir), "prioritized",
         *(["lookahead"] if task else []), "greedy", "random", "--episodes", str(args.episodes),
         "--json", str(run_dir / "evaluation.json")]
    )  # fmt: skip
    if code:
        return code
    print(
        "\n== the same episodes as one table"
        + (", with the lower bound" if args.bound_time > 0 else "")
    )
    code = main(
        ["seed-table", str(run_dir / "evaluation.json"), "--bound-time", str(args.bound_time),
         "--out", str(run_dir / "evaluation.md")]
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
