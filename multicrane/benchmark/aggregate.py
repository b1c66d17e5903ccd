"""Table I's metric over a sweep's result files: one cell (configuration x algorithm) of
mean +- standard error over seeds, beside the exact planner's return.

The metric (the same as the paper's protocol, ``docs/paper-spec.md`` section 8): for each
seed, the *final return* is ``result["final"]["return_mean"]``, the mean return of the
trained policy acting greedily (deterministic actions) over the final evaluation's
``final_episodes`` episodes (``eval_episodes`` when unset), on the reset seeds 1000000,
1000001, ... (the same episodes for every algorithm and seed). A cell (configuration,
algorithm) reports the mean of the final returns over its seeds +- their standard error
(``multicrane.stats.mean_sem``: sample standard deviation with n - 1, divided by sqrt(n)).
With a single seed there is no spread to estimate: the standard error is None, shown "n/a"
(not 0, which would claim a certainty one seed cannot give).

Beside it: the success rate (mean over seeds of the final evaluation's success rate), the
exact planner's return on the same evaluation episodes (``final.optimal_mean``), the gap
optimal - ours and that gap in percent of |optimal|, and the mean return of the last 100
training episodes (exploration on; the literal reading of Table I's caption).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from multicrane.benchmark.profiles import Sweep
from multicrane.benchmark.runstate import RESULT, config_differences, read_result
from multicrane.stats import mean_sem

LABELS = {
    "dqn": "DQN",
    "double_dqn": "double DQN",
    "a2c": "A2C",
    "ppo": "PPO",
    "maskable_ppo": "MaskablePPO",
    "lean_ppo": "lean PPO",
}

Results = dict[tuple[str, str], dict[int, dict | None]]  # (config, algo) -> seed -> result


@dataclass(frozen=True)
class Cell:
    """One configuration and algorithm over the sweep's seeds."""

    config: str
    algo: str
    seeds: tuple[int, ...]  # the seeds the sweep asks for
    finals: dict[int, float]  # seed -> final return, for the finished seeds
    success: dict[int, float]
    optimal: dict[int, float]
    train_returns: dict[int, float]
    train_seconds: dict[int, float]

    @property
    def n(self) -> int:
        return len(self.finals)

    @property
    def missing(self) -> tuple[int, ...]:
        return tuple(s for s in self.seeds if s not in self.finals)

    @property
    def mean(self) -> float | None:
        return mean_sem(list(self.finals.values()))[0]

    @property
    def sem(self) -> float | None:
        return mean_sem(list(self.finals.values()))[1]

    @property
    def success_rate(self) -> float | None:
        return mean_sem(list(self.success.values()))[0]

    @property
    def optimal_mean(self) -> float | None:
        """The planner's mean return on the evaluation episodes (the same for every seed
        when the evaluation episodes are; averaged all the same)."""
        return mean_sem(list(self.optimal.values()))[0]

    @property
    def gap(self) -> float | None:
        """Optimal - ours (>= 0 up to the planner being exact)."""
        if self.mean is None or self.optimal_mean is None:
            return None
        return self.optimal_mean - self.mean

    @property
    def gap_pct(self) -> float | None:
        if self.gap is None or not self.optimal_mean:
            return None
        return 100.0 * self.gap / abs(self.optimal_mean)

    @property
    def train_return(self) -> tuple[float | None, float | None]:
        return mean_sem(list(self.train_returns.values()))

    def to_dict(self) -> dict[str, Any]:
        train_mean, train_sem = self.train_return
        return {
            "config": self.config,
            "algo": self.algo,
            "seeds": list(self.seeds),
            "finished_seeds": sorted(self.finals),
            "missing_seeds": list(self.missing),
            "final_returns": {str(s): v for s, v in sorted(self.finals.items())},
            "return_mean": self.mean,
            "return_sem": self.sem,
            "success_rate": self.success_rate,
            "optimal_mean": self.optimal_mean,
            "gap": self.gap,
            "gap_pct": self.gap_pct,
            "train_return_mean": train_mean,
            "train_return_sem": train_sem,
            "train_seconds": sum(self.train_seconds.values()),
        }


def make_cell(config: str, algo: str, results: Mapping[int, dict | None]) -> Cell:
    """A cell from per-seed result dicts; None marks a seed without a result."""
    finals, success, optimal, train, seconds = {}, {}, {}, {}, {}
    for seed, result in results.items():
        if result is None:
            continue
        final = result["final"]
        finals[seed] = float(final["return_mean"])
        if final.get("success_rate") is not None:
            success[seed] = float(final["success_rate"])
        if final.get("optimal_mean") is not None:
            optimal[seed] = float(final["optimal_mean"])
        if result.get("train_return_mean") is not None:
            train[seed] = float(result["train_return_mean"])
        seconds[seed] = float(result.get("train_seconds") or 0.0) + float(
            result.get("eval_seconds") or 0.0
        )
    return Cell(config, algo, tuple(results), finals, success, optimal, train, seconds)


def collect(sweep: Sweep) -> tuple[Results, list[str]]:
    """Every run's result (None where there is no valid result of this sweep's
    configuration) and a note for each result file that could not be used."""
    results: Results = {}
    problems = []
    for spec in sweep.runs():
        path = spec.dir(sweep.out) / RESULT
        result = None
        if path.exists():
            result, problem = read_result(path)
            if problem:
                problems.append(problem)
            elif diff := config_differences(result["config"], spec.train):
                problems.append(f"{path}: another configuration ({'; '.join(diff)})")
                result = None
        results.setdefault((spec.config, spec.algo), {})[spec.seed] = result
    return results, problems


def make_cells(sweep: Sweep, results: Results) -> list[Cell]:
    """Every configuration x algorithm; a pair the sweep does not run (``algo_configs``) gets
    a cell without seeds."""
    return [
        make_cell(config, algo, results.get((config, algo), dict.fromkeys(
            sweep.seeds if config in sweep.algo_configs.get(algo, sweep.configs) else ())))
        for config in sweep.configs
        for algo in sweep.algos
    ]


def summary(sweep: Sweep, cells: Sequence[Cell]) -> dict[str, Any]:
    """The aggregated numbers as one JSON-ready dict."""
    return {
        "sweep": sweep.to_dict(),
        "metric": METRIC,
        "cells": [c.to_dict() for c in cells],
    }


METRIC = (
    'per seed, result["final"]["return_mean"] (mean return of the trained policy with greedy '
    "actions over the final evaluation episodes, reset seeds 1000000..); then the mean over "
    "seeds +- the standard error over seeds (sample std with n-1 / sqrt(n); None for one seed)"
)

