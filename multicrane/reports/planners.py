"""Run classical multi-crane planners on scenarios x crane counts and collect their results.

The policies come in as arguments (``make_policy(env, seed)`` by name); nothing here knows a
planner. Each (scenario, crane count, policy) plays the episodes ``reset(seed=first + i)``
starts in ``MultiCraneEnv``'s default (claiming) mode, through ``multicrane.episodes.rollout``
(the task-mode cost too: ``play``, timed per episode, reset included). For the paper's
configurations (e?s?) with one crane, an exact single-agent planner (paper mode, automatic
claiming and assembly) gives the optimum on the same layouts; its step count is converted to
the claiming mode's (``comparable``: steps - pass-over steps + 2 per component, since a claim
step lifts a component and an assemble step ends it).
"""

from __future__ import annotations

import re
import statistics
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from multicrane.core.schema import Scenario
from multicrane.episodes.rollout import evaluate, play, run_episode
from multicrane.scenario.loader import load_scenario
from multicrane.sim.reach import crane_count_problem

PLANNERS = ("greedy", "prioritized")
PAPER = re.compile(r"^e[1-4]s[1-4]$")
LARGE = ("frame2-3c", "hall-4c", "towers-3c")
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
    bound: bool = True  # the CP-SAT makespan lower bound of each planner seed's episode
    bound_time_limit: float = 60.0  # seconds per bound
    task_cost: bool = True  # task-mode prioritized on the large scenarios: rounds and cost
    # Scenarios given as objects (a named set's sites), by the name used in ``scenarios``.
    sites: dict[str, Scenario] = field(default_factory=dict)

    def scenario(self, name: str) -> str | Scenario:
        """What ``name`` stands for: a site of ``sites``, else the shipped name itself."""
        return self.sites.get(name, name)

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
class Bound:
    """The makespan lower bound of each planner seed's episode (``multicrane.bounds.makespan``)."""

    values: list[int]  # per seed, in the order of ``Setup.seeds_of("prioritized")``
    proven: int  # how many are the relaxation's proven optimum
    seconds: float


@dataclass
class TaskCost:
    """The prioritized rule in task mode (``decisions="task"``) on one setting."""

    makespans: list[int | None]  # per seed (None: not completed)
    same_as_motion: bool  # every makespan equals the motion-mode planner's on the same seed
    rounds: float  # decision rounds (``env.step`` calls) per episode
    ms_per_round: float  # wall time per decision round, planning and simulation included


@dataclass
class Results:
    """Everything a report needs: the setup, the cells, the optima and the wall time."""

    setup: Setup
    cells: dict[tuple[str, int, str], Cell]
    optimal: dict[str, Optimal]
    wall: float
    # (scenario, cranes) settings not run, with the reason (crane reach: too few cranes)
    skipped: dict[tuple[str, int], str] = field(default_factory=dict)
    bounds: dict[tuple[str, int], Bound] = field(default_factory=dict)
    task: dict[tuple[str, int], TaskCost] = field(default_factory=dict)

    def gaps(self, name: str, n: int, policy: str) -> list[float]:
        """Per completed episode: (makespan - bound) / bound, the episode's own bound."""
        cell, bound = self.cells.get((name, n, policy)), self.bounds.get((name, n))
        if cell is None or bound is None:
            return []
        by_seed = dict(zip(self.setup.seeds_of("prioritized"), bound.values, strict=True))
        return [
            (r["makespan"] - by_seed[r["seed"]]) / by_seed[r["seed"]]
            for r in cell.results
            if r["success"] and r["seed"] in by_seed
        ]


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
    from multicrane.envs.paper_env import PaperAssemblyEnv

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


def run_bound(name: str | Scenario, n: int, seeds: range, time_limit: float) -> Bound:
    """The lower bound of each seed's episode of (scenario, cranes)."""
    from multicrane.bounds.makespan import lower_bound

    start = time.perf_counter()
    results = [lower_bound(name, n, seed=s, time_limit=time_limit) for s in seeds]
    return Bound(
        [b.value for b in results], sum(b.optimal for b in results), time.perf_counter() - start
    )


def run_task_cost(name: str, n: int, make_policy: MakePolicy, motion: Cell) -> TaskCost:
    """The prioritized rule in task mode on the seeds of the motion-mode cell ``motion``."""
    from multicrane import parallel_env

    env = parallel_env(name, n_cranes=n, decisions="task")
    spans, rounds, seconds = [], 0, 0.0
    for r in motion.results:
        policy = make_policy(env, r["seed"])
        start = time.perf_counter()
        rounds += play(env, policy, r["seed"])
        seconds += time.perf_counter() - start
        spans.append(env.sim.state.step_count if env.sim.done else None)
    same = spans == [r["makespan"] for r in motion.results]
    episodes = len(motion.results)
    return TaskCost(spans, same, rounds / episodes, 1000.0 * seconds / max(rounds, 1))


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
    bounds: dict[tuple[str, int], Bound] = {}
    task: dict[tuple[str, int], TaskCost] = {}
    start = time.perf_counter()
    for name in setup.scenarios:
        for n in setup.cranes:
            problem = crane_count_problem(load_scenario(setup.scenario(name)), n)
            if problem is not None:  # a tower-crane scenario needs more of its cranes
                skipped[name, n] = problem
                if log is not None:
                    log(f"{name:<10} {n} skipped: {problem}")
                continue
            env = parallel_env(setup.scenario(name), n_cranes=n)
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
            extra = run_extras(setup, policies, name, n, cells, log)
            if extra[0] is not None:
                bounds[name, n] = extra[0]
            if extra[1] is not None:
                task[name, n] = extra[1]
        if setup.optimal and make_optimal and PAPER.match(name) and 1 in setup.cranes:
            optimal[name] = run_optimal(name, make_optimal, setup.seeds_of("prioritized"))
    wall = time.perf_counter() - start
    return Results(setup, cells, optimal, wall, skipped, bounds, task)


def run_extras(
    setup: Setup,
    policies: Mapping[str, MakePolicy],
    name: str,
    n: int,
    cells: dict[tuple[str, int, str], Cell],
    log: Callable[[str], None] | None,
) -> tuple[Bound | None, TaskCost | None]:
    """The lower bound of (scenario, cranes), and the task-mode cost on a large scenario."""
    bound = task = None
    if setup.bound and setup.seeds:
        bound = run_bound(
            setup.scenario(name), n, setup.seeds_of("prioritized"), setup.bound_time_limit
        )
        if log is not None:
            log(f"{name:<10} {n} bound {bound.values} ({bound.seconds:.1f} s)")
    motion = cells.get((name, n, "prioritized"))
    if setup.task_cost and name in LARGE and motion is not None:
        task = run_task_cost(name, n, policies["prioritized"], motion)
        if log is not None:
            log(f"{name:<10} {n} task mode {task.ms_per_round:.2f} ms per decision round")
    return bound, task
