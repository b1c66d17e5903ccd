"""Best of K learned orders: the makespan of a scorer's sampled orders against K and temperature.

    .venv/bin/python tools/order_sampling.py --scorer runs/order-es21/es-s0 --samples 16 \\
        --temperature 0.25 0.5 1 2          # 64 train sites: where the temperature is chosen
    .venv/bin/python tools/order_sampling.py --scorer runs/order-es21/es-s0 --set test-small

``TaskPrioritized(rank=--rank, scorer=..., samples=K, temperature=T)`` plays, at reset, the
scorer's order and K - 1 orders drawn from the Plackett-Luce distribution of its scores on
copies of the site and keeps the shortest. This program draws the same candidates the same
way (the policy's seed from the reset seed, as ``multicrane evaluate`` seeds it), plays each
once and reports, per temperature and for k = 1, 2, 4, ... K, what the policy with
``samples=k`` plays (the first k candidates of K are those of k): the mean makespan, its ratio
to the prioritized planner's (in brackets the mean of per-site ratios), the sites longer than
the planner and the worst site. The sites: ``--set NAME`` (a held-out set, each site from the
first evaluation seed, the episode ``evaluate --episodes 1`` plays), or ``--sites`` ``train``
sites within ``--max-components`` and ``--cranes``, drawn from ``--seed`` by a stream of
their own (not the one of ``tools/order_es.py``'s training or validation sites; a site may
still be one of those by chance). ``--other-ranks list nearest --other-samples M``, a
diagnostic no policy plays: the first M orders also under those ranks, and the best of all the
candidates. Base install only.
"""

from __future__ import annotations

import argparse
import sys
from multiprocessing import Pool
from pathlib import Path

import numpy as np

import multicrane
from multicrane.episodes.rollout import run_episode
from multicrane.scenario.named_sets import draw_train_seeds, members
from multicrane.tasks.order_scorer import OrderScorer, component_features
from multicrane.tasks.priority_rule import RANKS
from policies.registry import policy_seed
from policies.task_planners import TaskPrioritized, load_scorer

sys.path.insert(0, str(Path(__file__).parent))  # tools/ is not a package
from order_es import site_episode  # noqa: E402


def candidate_spans(site, scorer: OrderScorer, rank: str, samples: int, temperature: float,
                    other_ranks: tuple[str, ...] = (),
                    other_samples: int = 0) -> tuple[float, list[float]]:  # fmt: skip
    """On one site: the planner's makespan and each candidate order's under ``rank``, in the
    policy's order of candidates, then the first ``other_samples`` of them under each of
    ``other_ranks`` (an unfinished episode: ``inf``)."""
    scenario, seed = site_episode(site)
    env = multicrane.parallel_env(scenario, decisions="task")
    planner = run_episode(env, TaskPrioritized(env), seed)["makespan"]
    env.reset(seed=seed)
    features = component_features(env.unwrapped.mode.task_book(), scenario)
    rng = np.random.default_rng(policy_seed(seed))
    orders = scorer.sampled_orders(features, scenario, samples, temperature, rng)
    candidates = [(rank, order) for order in orders]
    candidates += [(other, order) for other in other_ranks for order in orders[:other_samples]]
    spans = []
    for r, order in candidates:
        span = run_episode(env, TaskPrioritized(env, rank=r, order=order), seed)["makespan"]
        spans.append(np.inf if span is None else float(span))
    return (np.inf if planner is None else float(planner)), spans


def _job(job) -> tuple[float, list[float]]:
    return candidate_spans(*job)


def curve(planner: np.ndarray, spans: np.ndarray) -> list[dict]:
    """Per k = 1, 2, 4, ... up to the candidates' count (and the count itself): the best of
    the first k candidates on each site against the planner's makespans."""
    ks = sorted({k for k in (2**i for i in range(16)) if k < spans.shape[1]} | {spans.shape[1]})
    rows = []
    for k in ks:
        best = spans[:, :k].min(axis=1)
        ratio = best / planner
        rows.append({"samples": k, "makespan": float(best.mean()),
                     "ratio": float(best.mean() / planner.mean()),
                     "site_ratio": float(ratio.mean()), "longer": int((ratio > 1).sum()),
                     "worst": float(ratio.max())})  # fmt: skip
    return rows


def _print_row(label: str, row: dict) -> None:
    print(f"  {label}: {row['makespan']:7.1f}  {row['ratio']:.4f} ({row['site_ratio']:.4f})  "
          f"longer on {row['longer']:3d}, worst {row['worst']:.3f}")


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scorer", required=True,
                   help="a scorer file, a run directory or a shipped scorer's name")
    p.add_argument("--samples", type=int, default=16, help="K, the candidates per site")
    p.add_argument("--temperature", type=float, nargs="+", default=[0.5])
    p.add_argument("--rank", default="chain", choices=RANKS)
    p.add_argument("--other-ranks", nargs="+", default=[], choices=RANKS,
                   help="also play the first --other-samples orders under these ranks")
    p.add_argument("--other-samples", type=int, default=8)
    p.add_argument("--set", help="a held-out set (else train sites)")
    p.add_argument("--sites", type=int, default=64, help="train sites")
    p.add_argument("--max-components", type=int, default=40)
    p.add_argument("--cranes", type=int, nargs=2, default=[1, 4], metavar=("LO", "HI"))
    p.add_argument("--seed", type=int, default=0, help="the draw of the train sites")
    p.add_argument("--workers", type=int, default=2)
    return p


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    if args.samples < 1 or min(args.temperature) <= 0:
        raise SystemExit("--samples must be at least 1 and every --temperature positive")
    if args.other_ranks and not 1 <= args.other_samples <= args.samples:
        raise SystemExit(f"--other-samples must be 1 to --samples ({args.samples}), "
                         f"got {args.other_samples}")
    try:
        scorer = load_scorer(args.scorer)
        named = members(args.set) if args.set else []
    except ValueError as exc:
        raise SystemExit(f"order_sampling: {exc}") from None
    if args.set:
        sites = [f"{args.set}:{i}" for i in range(len(named))]
    else:
        rng = np.random.default_rng([args.seed, 3])
        sites = draw_train_seeds(rng, args.sites, args.max_components, tuple(args.cranes))
    where = args.set or f"{len(sites)} train sites"
    for temperature in args.temperature:
        jobs = [(s, scorer, args.rank, args.samples, temperature, tuple(args.other_ranks),
                 args.other_samples) for s in sites]  # fmt: skip
        if args.workers > 1:
            with Pool(args.workers) as pool:
                rows = pool.map(_job, jobs, chunksize=1)
        else:
            rows = list(map(_job, jobs))
        planner = np.array([r[0] for r in rows])
        spans = np.array([r[1] for r in rows])
        print(f"{where}, temperature {temperature}: prioritized {planner.mean():.1f}")
        for row in curve(planner, spans[:, : args.samples]):
            _print_row(f"best of {row['samples']:3d}", row)
        if args.other_ranks:
            row = curve(planner, spans)[-1]
            _print_row(f"and the first {args.other_samples} under "
                       f"{', '.join(args.other_ranks)} ({spans.shape[1]})", row)  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
