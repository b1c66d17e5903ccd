"""The uncertainty benchmark: makespan and completion of policies under disruption levels.

For every scenario x disruption level (``MultiCraneEnv(events=level)``: ``none``, ``low``,
``high``, see docs/uncertainty.md) x policy, episodes are played from reset seeds
``1000 * s + e`` (seed ``s`` of ``seeds``, episode ``e`` of ``episodes``) through
``multicrane.episodes.rollout.run_episode``; a cell holds the completion rate and the makespan of
the
completed episodes (mean and its 95 % confidence interval, ``multicrane.stats.ci95``). The
undisturbed site's proven makespan lower bound (``multicrane.bounds.makespan``, the same start
poses) is
computed once per scenario and seed. Policies are handed in as ``make_policy(env, seed)``
(``multicrane`` never imports ``policies``; the ``multicrane uncertainty`` command does); a
policy that decides tasks (a learned task-level policy) is played with
``decisions="task"``: its makespan is counted in the same simulated steps.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import asdict, dataclass, field

import multicrane.tables as tables
from multicrane.stats import ci95

LEVELS = ("none", "low", "high")
MakePolicy = Callable[..., Callable]


@dataclass
class Cell:
    """One (scenario, level, policy): the episodes' makespans (None: not completed)."""

    scenario: str
    n_cranes: int
    level: str
    policy: str
    seeds: list[int] = field(default_factory=list)
    makespans: list[int | None] = field(default_factory=list)
    wall_s: float = 0.0

    @property
    def completion(self) -> float:
        return sum(m is not None for m in self.makespans) / len(self.makespans)

    @property
    def done(self) -> list[int]:
        return [m for m in self.makespans if m is not None]

    @property
    def mean(self) -> float | None:
        return statistics.fmean(self.done) if self.done else None

    @property
    def ci(self) -> tuple[float, float] | None:
        return ci95(self.done)

    def as_dict(self) -> dict:
        out = asdict(self)
        out.update(completion=self.completion, mean=self.mean, ci95=self.ci)
        return out


@dataclass
class Bound:
    """The undisturbed site's proven lower bound, per seed, of one scenario."""

    scenario: str
    n_cranes: int
    values: list[int]
    statuses: list[str]

    @property
    def mean(self) -> float:
        return statistics.fmean(self.values)


def episode_seeds(seeds: int, episodes: int) -> list[int]:
    """The reset seeds of a cell: ``1000 * s + e``."""
    if seeds < 1 or episodes < 1:
        raise ValueError(f"seeds and episodes must be at least 1, got {seeds}, {episodes}")
    return [1000 * s + e for s in range(seeds) for e in range(episodes)]


def run_cell(
    scenario, n_cranes: int | None, level: str, policy: str, make_policy: MakePolicy,
    seeds: Sequence[int], decisions: str = "motion",
) -> Cell:  # fmt: skip
    """Play one cell's episodes, one environment reused (at the ``decisions`` level)."""
    from multicrane.envs.crane_env import MultiCraneEnv
    from multicrane.episodes.rollout import run_episode

    began = time.perf_counter()
    env = MultiCraneEnv(scenario, n_cranes=n_cranes, events=level, decisions=decisions)
    cell = Cell(env.scenario.name, env.sim.n_cranes, level, policy)
    for seed in seeds:
        result = run_episode(env, make_policy(env, seed), seed=seed)
        cell.seeds.append(seed)
        cell.makespans.append(result["makespan"])
    cell.wall_s = time.perf_counter() - began
    return cell


def undisturbed_bound(scenario, n_cranes: int | None, seeds: Sequence[int],
                      time_limit: float) -> Bound:  # fmt: skip
    """``multicrane.bounds.makespan.lower_bound`` of the undisturbed site for every seed (one
    worker)."""
    from multicrane.bounds.makespan import lower_bound

    results = [lower_bound(scenario, n_cranes, s, time_limit, workers=1) for s in seeds]
    first = results[0]
    return Bound(first.scenario, first.n_cranes, [r.value for r in results],
                 [r.status for r in results])  # fmt: skip


def run_benchmark(
    scenarios: Iterable[tuple], levels: Sequence[str], policies: dict[str, MakePolicy],
    seeds: Sequence[int], bound_time: float = 10.0,
    progress: Callable[[str], None] | None = None, decisions: dict[str, str] | None = None,
) -> tuple[list[Cell], list[Bound]]:  # fmt: skip
    """Every scenario x level x policy cell, and each scenario's bound (``bound_time`` <= 0:
    no bound); ``scenarios``: (scenario, crane count or None for its own) pairs;
    ``decisions``: the decision level of a policy by name (default ``"motion"``)."""
    decisions = decisions or {}
    for level in levels:
        if level not in LEVELS:
            raise ValueError(f"level must be one of {', '.join(LEVELS)}, got {level!r}")
    cells, bounds = [], []
    for scenario, n_cranes in scenarios:
        if bound_time > 0:
            bounds.append(undisturbed_bound(scenario, n_cranes, seeds, bound_time))
        for level in levels:
            for name, make in policies.items():
                cell = run_cell(scenario, n_cranes, level, name, make, seeds,
                                decisions.get(name, "motion"))  # fmt: skip
                cells.append(cell)
                if progress is not None:
                    progress(describe(cell))
    return cells, bounds


def describe(cell: Cell) -> str:
    """One line about one cell."""
    return (
        f"{cell.scenario} ({cell.n_cranes} cranes), events {cell.level}, {cell.policy}: "
        f"completed {cell.completion:.0%}, makespan {fmt_mean(cell)} ({cell.wall_s:.1f} s)"
    )


def fmt_mean(cell: Cell) -> str:
    """``mean [lo, hi]`` of the completed episodes' makespans (``-`` when none)."""
    if cell.mean is None:
        return "-"
    ci = cell.ci
    return f"{cell.mean:.1f}" + ("" if ci is None else f" [{ci[0]:.1f}, {ci[1]:.1f}]")


def markdown_table(cells: list[Cell], bounds: list[Bound]) -> str:
    """Scenario x level rows, one column per policy: ``mean [95 % CI] (completion)``, and
    the undisturbed bound's mean over seeds."""
    names = list(dict.fromkeys(c.policy for c in cells))
    bound_of = {(b.scenario, b.n_cranes): b for b in bounds}
    head = ["scenario", "cranes", "events", *names]
    if bounds:
        head.append("bound (undisturbed)")
    rows: dict[tuple, dict[str, Cell]] = {}
    for c in cells:
        rows.setdefault((c.scenario, c.n_cranes, c.level), {})[c.policy] = c
    table_rows = []
    for (scenario, n, level), by in rows.items():
        out = [scenario, str(n), level]
        for name in names:
            c = by.get(name)
            out.append("" if c is None else f"{fmt_mean(c)} ({c.completion:.0%})")
        if bounds:
            b = bound_of.get((scenario, n))
            out.append("" if b is None else f"{b.mean:.1f}")
        table_rows.append(out)
    return "\n".join(tables.markdown_table(head, table_rows, align="l" * len(head)))


__all__ = ["LEVELS", "Bound", "Cell", "episode_seeds", "markdown_table", "run_benchmark",
           "run_cell", "undisturbed_bound"]  # fmt: skip
