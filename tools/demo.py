"""The main job: train parameter-sharing PPO for cranes, compare it, and save a replay.

    python tools/demo.py                                  # the defaults below, ~10 minutes
    python tools/demo.py --scenario e1s1 --cranes 2 --steps 400000

1. ``tools/train.py``: MaskablePPO with one policy shared by every crane, on a multi-crane
   scenario, for a short budget (resumes or reuses a finished run in ``--out``).
2. ``tools/evaluate.py``: the trained policy beside the prioritized planner, greedy and
   random cranes, on the same episodes.
3. ``tools/replay.py record``: one episode of the trained policy as a rerun replay
   (``.rrd``, open it with ``rerun FILE``) and an episode record (``.json.gz``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from tools import evaluate, replay, train  # noqa: E402

DEFAULTS = {"scenario": "e2s2", "cranes": 2, "steps": 1_000_000, "algo": "maskable_ppo"}


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--scenario", default=DEFAULTS["scenario"])
    p.add_argument("--cranes", type=int, default=DEFAULTS["cranes"])
    p.add_argument("--steps", type=int, default=DEFAULTS["steps"], help="crane decisions")
    p.add_argument("--algo", default=DEFAULTS["algo"], choices=("ppo", "maskable_ppo"))
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--episodes", type=int, default=20, help="evaluation episodes")
    p.add_argument("--out", type=Path, default=Path("runs/demo"))
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    run_dir = args.out / f"{args.scenario}-{args.cranes}c-{args.algo}-s{args.seed}"
    where = ["--scenario", args.scenario, "--cranes", str(args.cranes)]
    print(f"== 1. train {args.algo} (shared by {args.cranes} cranes) on {args.scenario}")
    code = train.main(
        [*where, "--algo", args.algo, "--steps", str(args.steps), "--seed", str(args.seed),
         "--eval-every", str(max(args.steps // 10, 1)), "--out", str(run_dir)]
    )  # fmt: skip
    if code:
        return code
    print(f"\n== 2. evaluate ({args.episodes} episodes, the same seeds for every policy)")
    code = evaluate.main(
        [*where, "--policy", str(run_dir), "prioritized", "greedy", "random",
         "--episodes", str(args.episodes), "--json", str(run_dir / "evaluation.json")]
    )  # fmt: skip
    if code:
        return code
    print("\n== 3. replay one episode of the trained policy")
    code = replay.main(
        ["record", *where, "--policy", str(run_dir), "--seed", "1000000",
         "--rrd", str(run_dir / "replay.rrd"), "--record", str(run_dir / "episode.json.gz")]
    )  # fmt: skip
    if code:
        return code
    print(
        f"\nwatch it: .venv/bin/rerun {run_dir / 'replay.rrd'}    "
        f"learning curves: .venv/bin/tensorboard --logdir {run_dir / 'tb'}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
