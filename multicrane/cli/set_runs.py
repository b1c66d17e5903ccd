"""Policies over a named scenario set (``set:NAME``): one row per site, then the set's means."""

from __future__ import annotations

import argparse

from multicrane.cli.common import make_env


def run_set(args: argparse.Namespace, makers: list, header: str, line) -> int:
    """``multicrane plan set:NAME``: every policy on every site of the set, episodes seeded
    from ``--seed``; prints each site's row and, per policy, the means over the set."""
    from multicrane.episodes.rollout import evaluate
    from multicrane.scenario.named_sets import resolve_set

    sites = resolve_set(args.scenario)
    seeds = list(range(args.seed, args.seed + args.episodes))
    options = {} if args.max_steps is None else {"max_steps": args.max_steps}
    if getattr(args, "events", None) is not None:  # multicrane plan --events
        options["events"] = args.events
    if getattr(args, "decisions", None) is not None:  # multicrane plan --decisions
        options["decisions"] = args.decisions
    totals: dict[str, list[dict]] = {m.label: [] for m in makers}
    print(f"scenario set {args.scenario[len('set:') :]}: {len(sites)} sites")
    print(f"{'site':<28} " + header)
    for name, scenario in sites:
        env = make_env(None, scenario, args.cranes, args.auto, **options)
        for make in makers:
            _, summary = evaluate(env, make, seeds)
            totals[make.label].append(summary)
            print(f"{name.split('/')[-1][:28]:<28} " + line(make.label, summary, True))
    print(f"\nmeans over the set ({len(sites)} sites x {len(seeds)} episode(s)):")
    for label, rows in totals.items():
        mean = {
            key: sum(r[key] for r in rows) / len(rows)
            for key in ("return_mean", "success_rate", "steps_mean", "utilisation_mean",
                        "blocked_moves_mean", "plan_ms_per_step")
        }  # fmt: skip
        spans = [r["makespan_mean"] for r in rows if r.get("makespan_mean") is not None]
        mean["makespan_mean"] = sum(spans) / len(spans) if spans else None
        mean["return_sem"] = None
        print(f"{'(set mean)':<28} " + line(label, mean, True))
    return 0
