"""Run classical multi-crane planners on scenarios x crane counts and collect their results.

The policies come in as arguments (``make_policy(env, seed)`` by name); nothing here knows a
planner. Each (scenario, crane count, policy) plays the episodes ``reset(seed=first + i)``
starts in ``MultiCraneEnv``'s default (claiming) mode, through ``multicrane.rollout``. For the
paper's configurations (e?s?) with one crane, an exact single-agent planner (paper mode,
automatic claiming and assembly) gives the optimum on the same layouts; its step count is
converted to the claiming mode's (``comparable``: steps - pass-over steps + 2 per component,
since a claim step lifts a component and an assemble step ends it).
"""

from __future__ import annotations

import re
import statistics
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from multicrane.reach import crane_count_problem
from multicrane.rollout import evaluate, run_episode
from multicrane.scenario_loader import load_scenario

PLANNERS = ("greedy", "prioritized")
PAPER = re.compile(r"^e[1-4]s[1-4]$")
LARGE = ("frame2-3c", "hall-4c")
STAT_KEYS = ("searches", "failed", "expansions", "claims", "replans", "repairs", "fallbacks")

MakePolicy = Callable[..., Callable]
Advance = Callable[[int], None]


@dataclass(frozen=True)
class Setup:
    """What to run: scenarios x crane counts x policies, and the episode seeds."""

    scenarios: list[str]
    cranes: list[int]
    policies: list[str]
    seeds: int = 5  # episodes per setting, planners
    random_seeds: int = 2  # episodes per setting, random
    seed: int = 0  # first episode seed
    optimal: bool = True

    def seeds_of(self, policy: str) -> range:
        n = self.random_seeds if policy == "random" else self.seeds
        return range(self.seed, self.seed + n)

    def episodes(self) -> int:
        """Episodes in all (for a progress bar)."""
        per = sum(len(self.seeds_of(p)) for p in self.policies)
        return len(self.scenarios) * len(self.cranes) * per


@dataclass
class Cell:
    """One policy on one (scenario, crane count): per-episode results and their summary."""

    results: list[dict]
    summary: dict
    seconds: float
    stats: dict = field(default_factory=dict)  # planner counters (prioritized only)


@dataclass
class Optimal:
    steps: float
    comparable: float  # steps - pass-overs + 2 per component assembled
    success: float
    seconds: float


@dataclass
class Results:
    """Everything a report needs: the setup, the cells, the optima and the wall time."""

    setup: Setup
    cells: dict[tuple[str, int, str], Cell]
    optimal: dict[str, Optimal]
    wall: float
    # (scenario, cranes) settings not run, with the reason (crane reach: too few cranes)
    skipped: dict[tuple[str, int], str] = field(default_factory=dict)


def run_cell(
    env, make_policy: MakePolicy, seeds: range, advance: Advance | None = None
) -> Cell:
    """One policy on every seed of ``env``; the planners' counters are summed if they have any."""
    made = []

    def make(env, seed):
        policy = make_policy(env, seed)
        made.append(policy)
        if advance is not None:
            advance(1)
        return policy

    start = time.perf_counter()
    results, summary = evaluate(env, make, list(seeds))
    stats = dict.fromkeys(STAT_KEYS, 0)
    for policy in made:
        for k, v in getattr(policy, "stats", {}).items():
            stats[k] = stats.get(k, 0) + v
    return Cell(results, summary, time.perf_counter() - start, stats)


def run_optimal(config: str, make_optimal: MakePolicy, seeds: range) -> Optimal:
    """The exact planner on the paper configuration ``config`` for each seed."""
    from multicrane.paper_env import PaperAssemblyEnv

    env = PaperAssemblyEnv(config.upper())
    start = time.perf_counter()
    steps, comparable, success = [], [], []
    for seed in seeds:
        episode = run_episode(env, make_optimal(env, seed), seed=seed)
        passes = episode["events"].get("PASS_OVER", 0)
        steps.append(episode["steps"])
        comparable.append(episode["steps"] - passes + 2 * env.sim.k)
        success.append(episode["success"])
    return Optimal(
        statistics.fmean(steps),
        statistics.fmean(comparable),
        sum(success) / len(success),
        time.perf_counter() - start,
    )


def run_all(
    setup: Setup,
    policies: Mapping[str, MakePolicy],
    make_optimal: MakePolicy | None = None,
    advance: Advance | None = None,
    log: Callable[[str], None] | None = None,
) -> Results:
    """Every cell of ``setup``; ``policies[name]`` makes each policy, ``make_optimal`` (if
    given and ``setup.optimal``) the exact paper-mode planner. ``log`` gets one line per cell."""
    from multicrane import parallel_env

    cells: dict[tuple[str, int, str], Cell] = {}
    optimal: dict[str, Optimal] = {}
    skipped: dict[tuple[str, int], str] = {}
    start = time.perf_counter()
    for name in setup.scenarios:
        for n in setup.cranes:
            problem = crane_count_problem(load_scenario(name), n)
            if problem is not None:  # a tower-crane scenario needs more of its cranes
                skipped[name, n] = problem
                if log is not None:
                    log(f"{name:<10} {n} skipped: {problem}")
                continue
            env = parallel_env(name, n_cranes=n)
            for policy in setup.policies:
                seeds = setup.seeds_of(policy)
                if not len(seeds):
                    continue
                cell = run_cell(env, policies[policy], seeds, advance)
                cells[name, n, policy] = cell
                if log is not None:
                    s = cell.summary
                    made = "-" if s["makespan_mean"] is None else f"{s['makespan_mean']:.1f}"
                    log(
                        f"{name:<10} {n} {policy:<12} success {s['success_rate']:>4.0%} "
                        f"makespan {made} ({cell.seconds:.1f} s)"
                    )
        if setup.optimal and make_optimal and PAPER.match(name) and 1 in setup.cranes:
            optimal[name] = run_optimal(name, make_optimal, setup.seeds_of("prioritized"))
    return Results(setup, cells, optimal, time.perf_counter() - start, skipped)
