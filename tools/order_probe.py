"""Is a task-level planner's gain a static order? Its start order replayed as the rule's list.

    .venv/bin/python tools/order_probe.py --scenario set:test-small --policy lookahead:rank=chain

For each site (one episode from ``reset(seed=--seed)``, task decisions): plays ``--policy``
and takes the components in the order its cranes started them (each component's first
start; any never started follow in the scenario's order). Then, on the same episode, the
prioritized rule (``policies.task_planners.TaskPrioritized``) plays

- ``list``: with the scenario's list order (the plain planner),
- ``chain``: ``rank=chain`` with it,
- ``replayed``: with the start order as its list order (``order=``),
- ``classes``: ``rank=chain`` with the scenario's list order permuted only inside each class
  of interchangeable components (those with the same compatible targets): each class's places
  in the list go to its components in the start order, so only which yard component of a
  class goes first changes,
- ``swapped``: with the start order after ``--swaps`` exchanges of neighbours at random places
  (drawn from ``default_rng(--seed)``): how much of the order's gain survives small errors.

If ``replayed`` plays as short as ``--policy``, the policy's gain is a static per-site order
that the rule, given it, carries out; if not, the gain depends on what happens in the
episode. Prints each site's makespans and the means over the sites (``-`` for an episode that
did not finish). Needs nothing beyond the base install.
"""

from __future__ import annotations

import argparse
import statistics

import numpy as np

import multicrane
import policies
from multicrane.episodes.rollout import run_episode
from multicrane.scenario.named_sets import SET_PREFIX, resolve_set
from multicrane.tasks.order_scorer import interchangeable_classes
from policies.task_planners import TaskPrioritized

ROWS = ("policy", "list", "chain", "replayed", "classes", "swapped")


def start_order(env, actions: list[list[int]]) -> list[int]:
    """The components in the order the recorded joint task actions started them (first start
    each), then the others in the scenario's order."""
    base = env.unwrapped
    pairs = base.mode.task_book().tasks.pairs
    seen: dict[int, None] = {}
    for joint in actions:
        for a in joint:
            if a > 0:
                seen.setdefault(int(pairs[a - 1][0]), None)
    rest = [c for c in base.scenario.order if c not in seen]
    return list(seen) + rest


def classes(env) -> dict[tuple, list[int]]:
    """The classes of interchangeable components, each in the scenario's order."""
    base = env.unwrapped
    return interchangeable_classes(base.sim.site, base.scenario.order)


def within_classes(env, order: list[int]) -> list[int]:
    """The scenario's list order with each class of interchangeable components put in
    ``order``'s order, at the class's own places."""
    listed = list(env.unwrapped.scenario.order)
    slot = {c: i for i, c in enumerate(listed)}
    place = {c: i for i, c in enumerate(order)}
    for members in classes(env).values():
        for c, k in zip(sorted(members, key=place.__getitem__), members, strict=True):
            listed[slot[k]] = c
    return listed


def swapped(order: list[int], swaps: int, rng: np.random.Generator) -> list[int]:
    """``order`` with ``swaps`` neighbours exchanged, each at a uniformly drawn place."""
    out = list(order)
    for _ in range(swaps if len(out) > 1 else 0):
        i = int(rng.integers(len(out) - 1))
        out[i], out[i + 1] = out[i + 1], out[i]
    return out


def probe_site(scenario, spec: str, seed: int, swaps: int) -> dict[str, int | None]:
    """Each row's makespan on one site (``None``: unfinished)."""
    env = multicrane.parallel_env(scenario, decisions="task")
    played = run_episode(env, policies.make(spec, env, seed=seed), seed, record=True)
    order = start_order(env, played["actions"])
    makers = {
        "list": lambda: TaskPrioritized(env, seed=seed),
        "chain": lambda: TaskPrioritized(env, seed=seed, rank="chain"),
        "replayed": lambda: TaskPrioritized(env, seed=seed, order=order),
        "classes": lambda: TaskPrioritized(
            env, seed=seed, rank="chain", order=within_classes(env, order)
        ),
        "swapped": lambda: TaskPrioritized(
            env, seed=seed, order=swapped(order, swaps, np.random.default_rng(seed))
        ),
    }
    out = {"policy": played["makespan"]}
    for name, make in makers.items():
        out[name] = run_episode(env, make(), seed)["makespan"]
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument(
        "--scenario", default="set:test-small",
        help="a scenario name or file, or set:NAME (every site of the set)",
    )  # fmt: skip
    parser.add_argument(
        "--policy", default="lookahead:rank=chain",
        help="the task-level policy whose start order is replayed",
    )  # fmt: skip
    parser.add_argument("--seed", type=int, default=1_000_000, help="the episodes' reset seed")
    parser.add_argument(
        "--swaps", type=int, default=3,
        help="neighbours exchanged in the start order for the swapped row",
    )  # fmt: skip
    args = parser.parse_args(argv)
    sites = (resolve_set(args.scenario) if args.scenario.startswith(SET_PREFIX)
             else ((args.scenario, args.scenario),))  # fmt: skip
    print(f"{'site':<28}" + "".join(f"{r:>10}" for r in ROWS))
    spans: dict[str, list[int]] = {r: [] for r in ROWS}
    for name, scenario in sites:
        row = probe_site(scenario, args.policy, args.seed, args.swaps)
        for r in ROWS:
            if row[r] is not None:
                spans[r].append(row[r])
        cells = "".join(f"{'-' if row[r] is None else row[r]:>10}" for r in ROWS)
        print(f"{str(name).split('/')[-1][:27]:<28}" + cells)
    means = "".join(f"{statistics.fmean(spans[r]) if spans[r] else float('nan'):>10.1f}"
                    for r in ROWS)  # fmt: skip
    finished = ", ".join(f"{r} {len(spans[r])}" for r in ROWS)
    print(f"{f'mean ({len(sites)} sites)':<28}" + means + f"\nfinished: {finished}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
