"""Evaluate policies (trained models, planners, greedy, random) on a scenario and seeds.

    python tools/evaluate.py --paper E2S2 --policy runs/E2S2-ppo-s0 optimal greedy random
    python tools/evaluate.py --scenario e2s2 --cranes 2 \\
        --policy runs/e2s2-2c-maskable_ppo-s0 prioritized greedy random --episodes 50

A policy is ``optimal`` (paper mode), ``prioritized`` (multi-agent), ``greedy``, ``random``,
or a training run directory (``tools/train.py --out``). Every policy plays the same episodes:
reset seeds ``--seed`` .. ``--seed + episodes - 1`` (default: the evaluation seeds training
uses, 1000000..). Trained models act greedily. Prints, per policy: mean return ± standard
error over episodes, success rate, mean steps to finish (finished episodes), mean steps, and
in paper mode the gap to the exact planner's return on the same seeds.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import multicrane  # noqa: E402
from multicrane.rollout import evaluate, optimal_returns  # noqa: E402
from multicrane.training.seeding import evaluation_seeds  # noqa: E402
from policies import PolicyError, factory  # noqa: E402
from tools.report import add_environment_args  # noqa: E402


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    add_environment_args(p)
    p.add_argument("--policy", nargs="+", required=True, help="names or run directories")
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--seed", type=int, default=None, help="first reset seed")
    p.add_argument("--json", type=Path, help="also write the results here")
    return p.parse_args(argv)


def make_env(args: argparse.Namespace):
    if args.paper:
        # The mask changes no dynamics; masked models need it, the others ignore it.
        return multicrane.PaperAssemblyEnv(args.paper, mask_blocked_moves=True)
    return multicrane.parallel_env(args.scenario, n_cranes=args.cranes, auto=args.auto)


def evaluate_all(args: argparse.Namespace) -> list[dict]:
    paper = args.paper is not None
    env = make_env(args)
    if args.seed is None:
        seeds = evaluation_seeds(args.episodes)
    else:
        seeds = list(range(args.seed, args.seed + args.episodes))
    factories = [factory(spec, paper) for spec in args.policy]  # fail before running
    best = optimal_returns(env, seeds) if paper else None
    rows = []
    for make in factories:
        start = time.perf_counter()
        episodes, summary = evaluate(env, make, seeds, optimal=best)
        summary["seconds"] = round(time.perf_counter() - start, 3)
        rows.append({"policy": make.label, "summary": summary, "episodes": episodes})
    return rows


def format_table(rows: list[dict], paper: bool) -> str:
    head = f"{'policy':<44} {'return':>18} {'success':>8} {'finish':>7} {'steps':>7}"
    if paper:
        head += f" {'gap':>8} {'gap %':>7}"
    lines = [head]
    for row in rows:
        s = row["summary"]
        finish = "-" if s["finish_steps_mean"] is None else f"{s['finish_steps_mean']:.1f}"
        err = "-" if s["return_sem"] is None else f"{s['return_sem']:.2f}"
        line = (
            f"{row['policy'][:44]:<44} {s['return_mean']:>10.2f} ± {err:<6}"
            f"{s['success_rate']:>8.0%} {finish:>7} {s['steps_mean']:>7.1f}"
        )
        if paper:
            pct = "-" if s["gap_pct"] is None else f"{s['gap_pct']:.1f}"
            line += f" {s['gap']:>8.2f} {pct:>7}"
        lines.append(line)
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.episodes < 1:
        print("error: --episodes must be at least 1", file=sys.stderr)
        return 2
    try:
        rows = evaluate_all(args)
    except (PolicyError, multicrane.ScenarioError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    paper = args.paper is not None
    where = args.paper or f"{args.scenario}" + (f", {args.cranes} cranes" if args.cranes else "")
    print(f"{where}: {args.episodes} episodes per policy (same seeds for all)")
    print(format_table(rows, paper))
    if paper:
        print("gap = optimal return - policy return (exact planner on the same seeds)")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1, default=str) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
