"""One tuning run of the single-agent benchmark: train, then print CPU seconds and the result.

The runs of docs/benchmark-experiments.md were made with this program (developer-only; the
sweep itself is `multicrane benchmark run`). It trains one paper configuration with the
given learner settings and prints one JSON line: CPU and wall seconds, the final greedy
return over 20 evaluation episodes beside the exact optimum, the success rate, the mean
return of the last training episodes and the curve. Run from the project root, e.g.:

    PYTHONPATH=$PWD OMP_NUM_THREADS=1 python tools/paper_trial.py E2S2 maskable_ppo \
        --steps 200000 --hp '{"n_steps": 128, "batch_size": 128}' --envs 16 --seed 1 \
        --shaping 1 --potential path --shaping-gamma 1 --out runs/trials

(the `standard` profile's MaskablePPO settings; add ``"features": "grid_cnn"`` to ``--hp``
for the convolutional extractor).
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import time
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("config", help="paper configuration, e.g. E1S1")
    p.add_argument("algo", help="dqn, double_dqn, a2c, ppo or maskable_ppo")
    p.add_argument("--steps", type=int, default=200_000)
    p.add_argument("--hp", default="{}", help="learner settings over the paper's, as JSON")
    p.add_argument("--envs", type=int, default=None, help="environment copies")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--eval-every", type=int, default=50_000)
    p.add_argument("--shaping", type=float, default=0.0,
                   help="shaping weight of the learner's reward")  # fmt: skip
    p.add_argument("--potential", choices=("distance", "path"), default="distance",
                   help="the shaping potential (TrainConfig.potential)")  # fmt: skip
    p.add_argument("--shaping-gamma", type=float, default=None,
                   help="discount in the shaping term (default: the learner's)")  # fmt: skip
    p.add_argument("--out", type=Path, default=Path("runs/trials"),
                   help="parent of the run directory")  # fmt: skip
    p.add_argument("--log", type=Path, default=None, help="append the JSON line to this file")
    args = p.parse_args(argv)
    try:
        hp = json.loads(args.hp)
    except json.JSONDecodeError as exc:
        print(f"--hp {args.hp!r}: not JSON ({exc})", file=sys.stderr)
        return 2

    from multicrane.training import TrainConfig, train

    out = args.out / f"{args.config}-{args.algo}-s{args.seed}-w{args.shaping:g}"
    shutil.rmtree(out, ignore_errors=True)
    cfg = TrainConfig(
        scenario=args.config, paper=True, algo=args.algo, total_steps=args.steps,
        seed=args.seed, n_envs=args.envs, hyperparams=hp, eval_every=args.eval_every,
        eval_episodes=5, final_episodes=20, checkpoint_every=0, torch_threads=1,
        shaping=args.shaping, potential=args.potential, shaping_gamma=args.shaping_gamma,
    )  # fmt: skip
    wall0, cpu0 = time.perf_counter(), time.process_time()
    result = train(cfg, out, log=lambda *a: None)
    final = result["final"]
    line = {
        "config": args.config, "algo": args.algo, "seed": args.seed, "hp": hp,
        "n_envs": args.envs, "shaping": args.shaping,
        "potential": args.potential, "shaping_gamma": args.shaping_gamma, "steps": result["steps"],
        "wall": round(time.perf_counter() - wall0, 1),
        "cpu": round(time.process_time() - cpu0, 1),
        "return": round(final["return_mean"], 2),
        "optimum": round(final.get("optimal_mean", float("nan")), 2),
        "success": final["success_rate"], "train_return": result.get("train_return_mean"),
        "curve": [(q["step"], round(q["return_mean"], 1), q.get("success_rate"))
                  for q in result["curve"]],
    }  # fmt: skip
    print(json.dumps(line), flush=True)
    if args.log is not None:
        with args.log.open("a") as fh:
            fh.write(json.dumps(line) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
