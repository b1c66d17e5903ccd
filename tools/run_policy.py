"""Run policies on a scenario and print what they achieve.

    python tools/run_policy.py --scenario frame2-3c --cranes 3 --policy prioritized greedy random
    python tools/run_policy.py --scenario e2s2 --policy greedy --render   # watch one episode

Prints, per policy: mean team return ± standard error, success rate, mean steps (joint steps
to finish, the makespan on success) and blocked moves per episode.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import multicrane  # noqa: E402
import policies  # noqa: E402
from multicrane.rollout import run_episode  # noqa: E402
from multicrane.stats import sem  # noqa: E402


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--scenario", default="frame2-3c", help="shipped name or path to a .toml file")
    p.add_argument(
        "--cranes", type=int, default=None, help="number of cranes (default: scenario's)"
    )
    p.add_argument(
        "--policy",
        nargs="+",
        default=["prioritized", "greedy", "random"],
        choices=policies.names(False),
    )
    p.add_argument("--episodes", type=int, default=5)
    p.add_argument("--seed", type=int, default=0, help="first episode seed")
    p.add_argument("--auto", action="store_true", help="automatic claiming and assembly (paper)")
    p.add_argument("--render", action="store_true", help="print the site after the last episode")
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        env = multicrane.parallel_env(
            args.scenario, n_cranes=args.cranes, auto=args.auto, render_mode="ansi"
        )
    except multicrane.ScenarioError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    s = env.scenario
    print(
        f"scenario {s.name}: {s.n_components} components, {env.sim.n_cranes} crane(s), "
        f"site {s.size[0]}x{s.size[1]}x{s.size[2]}, step limit {env.step_limit}"
        + (", automatic mode" if args.auto else "")
    )
    print(f"{'policy':<8} {'return':>18} {'success':>8} {'steps':>8} {'blocked':>8} {'time':>7}")
    for name in args.policy:
        results = []
        start = time.perf_counter()
        for i in range(args.episodes):
            seed = args.seed + i
            results.append(run_episode(env, policies.make(name, env, seed), seed=seed))
        elapsed = time.perf_counter() - start
        returns = [r["return"] for r in results]
        err = sem(returns)
        err_text = "-" if err is None else f"{err:.2f}"
        print(
            f"{name:<8} {statistics.mean(returns):>10.2f} ± {err_text:<6}"
            f"{sum(r['success'] for r in results) / len(results):>8.0%}"
            f"{statistics.mean(r['steps'] for r in results):>9.1f}"
            f"{statistics.mean(r['blocked_moves'] for r in results):>9.1f}"
            f"{elapsed:>7.1f}s"
        )
    if args.render:
        print(env.render())
    return 0


if __name__ == "__main__":
    sys.exit(main())
