"""``multicrane evaluate``: put policies (trained models, planners, random) on the same seeds."""

from __future__ import annotations

import argparse
import sys
import time
from functools import lru_cache
from pathlib import Path

from multicrane.cli import progress
from multicrane.cli.common import (
    add_environment_args,
    counting,
    error,
    formatter,
    make_env,
    run_events,
)

DESCRIPTION = """Evaluate policies (trained models, planners, greedy, random) on a scenario
and seeds.

    multicrane evaluate --paper E2S2 --policy runs/E2S2-ppo-s0 optimal greedy random
    multicrane evaluate --scenario e2s2 --cranes 2 \\
        --policy runs/e2s2-2c-maskable_ppo-s0 prioritized greedy random --episodes 50
    multicrane evaluate --scenario set:test-small --policy prioritized greedy --episodes 2

A policy is optimal (paper mode), prioritized (multi-agent), greedy, random, lookahead (task
decisions), or a training run directory (multicrane train --out; needs the 'train' extra),
with options as NAME:KEY=VALUE,... (lookahead:candidates=20, prioritized:rank=nearest; the
look-ahead guided by a trained model: lookahead:guide=RUN_DIR; over a trained model, whose
rollouts it finishes: lookahead:base=RUN_DIR). Every policy plays the same
episodes: reset seeds --seed .. --seed + episodes - 1 (default: the evaluation seeds training
uses, 1000000..). Trained models act greedily. Prints, per policy: mean return ± standard
error over episodes, success rate, mean steps to finish (finished episodes), mean steps, and
in paper mode the gap to the exact planner's return on the same seeds. --scenario
set:test-small, set:test-large or set:train:FIRST-END evaluates on every site of a scenario
set (multicrane.scenario.named_sets): each row pools the episodes of all its sites (the set's
means);
--workers N plays its (policy, site) pairs in N processes, with the same episodes and results.
--events none|low|high plays the multi-agent mode with site events (docs/uncertainty.md);
without it, the scenario's own [events] table, or the level the run directories were
trained with (multicrane train --events).
--plot FILE.png draws every episode's makespan (return in paper mode, beside the exact
planner's) per policy, with the mean and its 95 % interval, one panel per site, and the
learning curves of the run directories against training wall time (matplotlib: the 'bench'
extra). --json keeps the episodes (and each run directory's path, as "run").
"""


def register(sub) -> None:
    p = sub.add_parser("evaluate", help="compare policies on the same seeds",
                       description=DESCRIPTION, **formatter())  # fmt: skip
    add_environment_args(p)
    p.add_argument("--policy", nargs="+", required=True,
                   help="names, run directories, NAME:KEY=VALUE,...")  # fmt: skip
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--seed", type=int, default=None, help="first reset seed")
    p.add_argument("--json", type=Path, help="also write the results here")
    p.add_argument("--plot", type=Path, metavar="FILE.png",
                   help="also draw the episodes and the runs' learning curves here")  # fmt: skip
    p.add_argument("--workers", type=int, default=1,
                   help="processes for a scenario set's (policy, site) pairs (one torch "
                   "thread each; same results as 1)")  # fmt: skip
    p.add_argument("--threads", type=int, default=1,
                   help="torch threads of the trained models in this process (default 1: "
                   "a small network's forward pass is slower on more; timings stay honest "
                   "beside other processes)")  # fmt: skip
    p.set_defaults(func=run)


def evaluate_all(args: argparse.Namespace, advance=None) -> list[dict]:
    """One row per policy: its label, summary and episodes (all on the same seeds)."""
    import policies
    from multicrane.episodes.rollout import evaluate, optimal_returns
    from multicrane.scenario.named_sets import is_set_ref
    from multicrane.training.seeding import evaluation_seeds

    paper = args.paper is not None
    if args.seed is None:
        seeds = evaluation_seeds(args.episodes)  # the seeds training evaluates on
    else:
        seeds = list(range(args.seed, args.seed + args.episodes))
    factories = [policies.factory(spec, paper=paper) for spec in args.policy]  # fail early
    if "torch" in sys.modules:  # a factory loaded a trained model (as policy, guide or base)
        sys.modules["torch"].set_num_threads(args.threads)
    events = None if paper else run_events(args.events, factories)
    if not paper and args.scenario and is_set_ref(args.scenario):
        return _evaluate_set(args, factories, seeds, advance, events)
    env = make_env(args.paper, args.scenario, args.cranes, args.auto, decisions=args.decisions,
                   events=args.events if paper else events)  # fmt: skip
    best = optimal_returns(env, seeds) if paper else None
    rows = []
    for make in factories:
        start = time.perf_counter()
        progress_ = counting(advance) if advance else None
        episodes, summary = evaluate(env, make, seeds, progress_, optimal=best)
        summary["seconds"] = round(time.perf_counter() - start, 3)
        for episode, optimal in zip(episodes, best, strict=True) if paper else ():
            episode["optimal_return"] = optimal  # the exact planner's return, same seed
        rows.append(_row(make, summary, episodes))
    return rows


def _row(make, summary: dict, episodes: list[dict]) -> dict:
    """One policy's row: its label, summary, episodes and, for a trained model, its path."""
    row = {"policy": make.label, "summary": summary, "episodes": episodes}
    if make.model is not None:
        row["run"] = make.name
    return row


def _evaluate_set(args: argparse.Namespace, factories: list, seeds: list[int], advance,
                  events: str | None = None) -> list:  # fmt: skip
    """One row per policy over every site of the set ``args.scenario`` (``set:NAME``): its
    summary pools the episodes of all sites (so the means are the set's means)."""
    from multicrane.episodes.rollout import summarise
    from multicrane.scenario.named_sets import set_members

    n_sites = len(set_members(args.scenario))
    if args.workers > 1:
        per_site, seconds = _play_in_workers(args, n_sites, seeds, events, advance)
    else:
        per_site, seconds = _play_here(args, factories, seeds, events, advance)
    rows = []
    for p, make in enumerate(factories):
        pooled = [e for s in range(n_sites) for e in per_site[p, s]]
        summary = summarise(pooled)
        summary["seconds"] = round(seconds[p], 3)  # summed over its sites
        summary["sites"] = n_sites
        rows.append(_row(make, summary, pooled))
    return rows


def _play_here(args: argparse.Namespace, factories: list, seeds: list[int],
               events: str | None, advance) -> tuple[dict, list[float]]:  # fmt: skip
    """Every (policy, site) pair of a set evaluation in this process (as _play_in_workers)."""
    from multicrane.scenario.named_sets import resolve_set

    per_site: dict[tuple[int, int], list[dict]] = {}
    seconds = [0.0] * len(factories)
    settings = (args.cranes, args.auto, args.decisions, events, seeds)
    sites = resolve_set(args.scenario)
    for p, make in enumerate(factories):
        for s, (_, scenario) in enumerate(sites):
            progress_ = counting(advance) if advance else None
            per_site[p, s], took = _play_site(scenario, make, *settings, progress_)
            seconds[p] += took
    return per_site, seconds


def _play_site(scenario, make, cranes, auto, decisions, events, seeds, progress_=None):
    """One policy's episodes on one site of a set, and the seconds they took."""
    from multicrane.episodes.rollout import evaluate

    start = time.perf_counter()
    env = make_env(None, scenario, cranes, auto, decisions=decisions, events=events)
    episodes, _ = evaluate(env, make, seeds, progress_)
    return episodes, time.perf_counter() - start


def _play_in_workers(args: argparse.Namespace, n_sites: int, seeds: list[int],
                     events: str | None, advance) -> tuple[dict, list[float]]:  # fmt: skip
    """Every (policy, site) pair of a set evaluation in ``args.workers`` processes: the
    episodes of each pair, and each policy's seconds summed over its sites."""
    import multiprocessing
    import os

    os.environ.setdefault("OMP_NUM_THREADS", "1")  # inherited by the spawned workers
    jobs = [(p, s) for s in reversed(range(n_sites)) for p in range(len(args.policy))]
    settings = (args.cranes, args.auto, args.decisions, events, seeds)
    ctx = multiprocessing.get_context("spawn")  # torch is loaded here: no fork
    per_site: dict[tuple[int, int], list[dict]] = {}
    seconds = [0.0] * len(args.policy)
    setup = (args.scenario, args.policy, settings)
    with ctx.Pool(args.workers, initializer=_worker_setup, initargs=setup) as pool:
        for p, s, episodes, took in pool.imap_unordered(_worker_play, jobs):
            per_site[p, s] = episodes
            seconds[p] += took
            if advance:
                advance(len(episodes))
    return per_site, seconds


_WORKER: dict = {}  # one worker process's set, policies and settings (_worker_setup)


@lru_cache(maxsize=8)
def _worker_site(index: int):
    """The set's site ``index``, generated in this worker the first time it plays it."""
    return _WORKER["sites"][index].scenario()


def _worker_setup(set_ref: str, specs: list[str], settings: tuple) -> None:
    import torch

    import policies
    from multicrane.scenario.named_sets import set_members

    torch.set_num_threads(1)
    makers = [policies.factory(s) for s in specs]
    _WORKER.update(sites=set_members(set_ref), makers=makers, settings=settings)


def _worker_play(job: tuple[int, int]) -> tuple[int, int, list[dict], float]:
    p, s = job
    episodes, took = _play_site(_worker_site(s), _WORKER["makers"][p], *_WORKER["settings"])
    return p, s, episodes, took


def _pm(summary: dict) -> str:
    sem = summary["return_sem"]
    return f"{summary['return_mean']:>10.2f} ± {'-' if sem is None else f'{sem:.2f}':<6}"


def format_table(rows: list[dict], paper: bool) -> str:
    width = max([44] + [len(row["policy"]) for row in rows])  # a whole label, options and all
    head = f"{'policy':<{width}} {'return':>18} {'success':>8} {'finish':>7} {'steps':>7}"
    if paper:
        head += f" {'gap':>8} {'gap %':>7}"
    lines = [head]
    for row in rows:
        s = row["summary"]
        finish = "-" if s["finish_steps_mean"] is None else f"{s['finish_steps_mean']:.1f}"
        line = (
            f"{row['policy']:<{width}} {_pm(s)}"
            f"{s['success_rate']:>8.0%} {finish:>7} {s['steps_mean']:>7.1f}"
        )
        if paper:
            pct = "-" if s["gap_pct"] is None else f"{s['gap_pct']:.1f}"
            line += f" {s['gap']:>8.2f} {pct:>7}"
        lines.append(line)
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    import json

    import multicrane
    from policies import PolicyError

    if args.episodes < 1:
        return error("--episodes must be at least 1")
    if args.workers < 1:
        return error("--workers must be at least 1")
    if args.threads < 1:
        return error(f"--threads {args.threads}: must be at least 1")
    from multicrane.scenario.named_sets import is_set_ref

    if args.workers > 1 and not (args.scenario and is_set_ref(args.scenario)):
        return error("--workers plays the sites of a scenario set in parallel: give --scenario "
                     "set:NAME (one scenario's episodes are played in one process)")  # fmt: skip
    if args.plot is not None:
        from multicrane.reports.comparison_plot import require_matplotlib

        require_matplotlib()  # before the episodes: a missing extra is said at once
    total = args.episodes * len(args.policy)
    try:
        with progress.bar(total, "evaluate") as advance:
            rows = evaluate_all(args, advance)
    except (PolicyError, multicrane.ScenarioError, ValueError) as exc:
        return error(exc)
    paper = args.paper is not None
    where = args.paper or f"{args.scenario}" + (f", {args.cranes} cranes" if args.cranes else "")
    sites = rows[0]["summary"].get("sites") if rows else None
    per = f"{args.episodes} episodes" + (f" per site x {sites} sites" if sites else "")
    print(f"{where}: {per} per policy (same seeds for all)")
    print(format_table(rows, paper))
    if paper:
        print("gap = optimal return - policy return (exact planner on the same seeds)")
    if args.json:
        from multicrane.files import write_atomic

        write_atomic(args.json, json.dumps(rows, indent=1, default=str) + "\n")
    if args.plot is not None:
        print(f"plot: {plot(rows, paper, args.plot, where)}")
    return 0


def plot(rows: list[dict], paper: bool, path: Path, title: str) -> Path:
    """The episodes per policy and the learning curves of the run directories, as a PNG."""
    from multicrane.reports.comparison_data import curve_panel, evaluate_panels, run_curves
    from multicrane.reports.comparison_plot import write_figure

    panels: list = evaluate_panels(rows, paper)
    curves = run_curves({row["policy"]: [row["run"]] for row in rows if "run" in row})
    if curves:
        panels.append(curve_panel(curves, paper))
    return write_figure(panels, path, title)
