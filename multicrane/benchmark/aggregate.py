"""Table I's metric over a sweep's result files, and the markdown page that shows it.

The metric (the same as the paper's protocol, ``docs/paper-spec.md`` section 8): for each
seed, the *final return* is ``result["final"]["return_mean"]``, the mean return of the
trained policy acting greedily (deterministic actions) over the final evaluation's
``final_episodes`` episodes (``eval_episodes`` when unset), on the reset seeds 1000000,
1000001, ... (the same episodes for every algorithm and seed). A cell (configuration,
algorithm) reports the mean of the final returns over its seeds +- their standard error
(sample standard deviation with n - 1, divided by sqrt(n)). With a single seed there is no
spread to estimate: the standard error is None, shown "n/a" (not 0, which would claim a
certainty one seed cannot give).

Beside it: the success rate (mean over seeds of the final evaluation's success rate), the
exact planner's return on the same evaluation episodes (``final.optimal_mean``), the gap
optimal - ours and that gap in percent of |optimal|, and the mean return of the last 100
training episodes (exploration on; the literal reading of Table I's caption).
"""

from __future__ import annotations

import json
import math
import statistics
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from multicrane.benchmark.reference import (
    PAPER_COLUMN,
    PAPER_MEANING,
    PAPER_SEEDS,
    PAPER_STEPS,
    SIGN_FIXED,
    table_i,
)
from multicrane.benchmark.sweep import RESULT, Sweep, config_differences, read_result

LABELS = {
    "dqn": "DQN",
    "double_dqn": "double DQN",
    "a2c": "A2C",
    "ppo": "PPO",
    "maskable_ppo": "MaskablePPO",
}

Results = dict[tuple[str, str], dict[int, dict | None]]  # (config, algo) -> seed -> result


def mean_sem(values: Sequence[float]) -> tuple[float | None, float | None]:
    """(mean, standard error of the mean) over ``values``: (None, None) for none, (x, None)
    for one, else the sample standard deviation (n - 1) over sqrt(n)."""
    values = [float(v) for v in values]
    if not values:
        return None, None
    if len(values) == 1:
        return values[0], None
    return statistics.fmean(values), statistics.stdev(values) / math.sqrt(len(values))


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
    return [
        make_cell(config, algo, results.get((config, algo), dict.fromkeys(sweep.seeds)))
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


# -- markdown ------------------------------------------------------------------------------------


def _num(value: float | None, digits: int = 2) -> str:
    return "n/a" if value is None else f"{value:.{digits}f}"


def _ours(cell: Cell, best: bool) -> str:
    if cell.n == 0:
        return "missing"
    text = f"{_num(cell.mean)} ± {_num(cell.sem)}"
    if best:
        text = f"**{text}**"
    if cell.missing:
        text += f" ({cell.n}/{len(cell.seeds)} seeds)"
    return text


def _paper(config: str, column: str) -> str:
    entry = table_i(config, column)
    if entry is None:
        return "—"
    mark = "\\*" if config in SIGN_FIXED and column == "PPO" else ""
    return f"{entry[0]:.2f} ± {entry[1]:.2f}{mark}"


def _paper_header(column: str) -> str:
    meaning = PAPER_MEANING[column]
    return f"Table I {column}" if meaning == column else f'Table I "{column}" ({meaning})'


def _table(header: list[str], align: str, rows: list[list[str]]) -> list[str]:
    """A markdown table; the first column left-aligned, the others ``align``."""
    rule = "|---|" + "|".join([align] * (len(header) - 1)) + "|"
    return ["| " + " | ".join(header) + " |", rule] + ["| " + " | ".join(r) + " |" for r in rows]


def _rows(sweep: Sweep, cells: Sequence[Cell]) -> dict[str, dict[str, Cell]]:
    by_config: dict[str, dict[str, Cell]] = {}
    for cell in cells:
        by_config.setdefault(cell.config, {})[cell.algo] = cell
    return {c: by_config[c] for c in sweep.configs if c in by_config}


def _optimal(row: dict[str, Cell]) -> float | None:
    values = [c.optimal_mean for c in row.values() if c.optimal_mean is not None]
    return statistics.fmean(values) if values else None


def return_table(sweep: Sweep, cells: Sequence[Cell]) -> list[str]:
    """Configurations x algorithms: ours beside the closest Table I columns."""
    header = ["config", "optimal"]
    for algo in sweep.algos:
        header.append(LABELS[algo])
        header += [_paper_header(col) for col in PAPER_COLUMN[algo]]
    rows = []
    for config, row in _rows(sweep, cells).items():
        means = [c.mean for c in row.values() if c.mean is not None]
        top = max(means) if len(means) > 1 else None
        line = [config, _num(_optimal(row))]
        for algo in sweep.algos:
            cell = row[algo]
            line.append(_ours(cell, top is not None and cell.mean == top))
            line += [_paper(config, col) for col in PAPER_COLUMN[algo]]
        rows.append(line)
    return _table(header, "---:", rows)


def success_gap_table(sweep: Sweep, cells: Sequence[Cell]) -> list[str]:
    """Success rate and gap to the optimum per algorithm."""
    header = ["config", "optimal"]
    header += [f"{LABELS[a]} success" for a in sweep.algos]
    header += [f"{LABELS[a]} gap" for a in sweep.algos]
    rows = []
    for config, row in _rows(sweep, cells).items():
        line = [config, _num(_optimal(row))]
        for algo in sweep.algos:
            rate = row[algo].success_rate
            line.append("missing" if rate is None else f"{rate:.0%}")
        for algo in sweep.algos:
            cell = row[algo]
            if cell.gap is None:
                line.append("missing" if cell.n == 0 else "n/a")
            else:
                pct = "" if cell.gap_pct is None else f" ({cell.gap_pct:.0f} %)"
                line.append(f"{cell.gap:.2f}{pct}")
        rows.append(line)
    return _table(header, "---:", rows)


def training_table(sweep: Sweep, cells: Sequence[Cell]) -> list[str]:
    header = ["config"] + [LABELS[a] for a in sweep.algos]
    rows = []
    for config, row in _rows(sweep, cells).items():
        line = [config]
        for algo in sweep.algos:
            mean, sem = row[algo].train_return
            line.append("missing" if mean is None else f"{_num(mean)} ± {_num(sem)}")
        rows.append(line)
    return _table(header, "---:", rows)


def markdown(
    sweep: Sweep,
    cells: Sequence[Cell],
    labels: Mapping[str, str],
    plots: Sequence[str] = (),
    problems: Sequence[str] = (),
    heading: str = "###",
) -> str:
    """The report: how the numbers were made, then the tables and the learning curves.

    ``labels``: ``run_command``, ``report_command``, ``date``, ``machine``, ``versions``,
    ``wall`` (free text, shown when present). ``plots``: image paths relative to the page."""
    total = len(sweep.configs) * len(sweep.algos) * len(sweep.seeds)
    finished = sum(c.n for c in cells)
    seeds = len(sweep.seeds)
    final_n = sweep.final_episodes or sweep.eval_episodes
    out = [
        f"{heading} Benchmark results: `{sweep.name}` sweep",
        "",
        f"Final return, mean ± standard error over {seeds} seed{'s' if seeds != 1 else ''}: "
        'for each seed, `result["final"]["return_mean"]`, the mean return of the trained '
        "policy acting greedily (deterministic actions) over the final evaluation's "
        f"{final_n} episodes (reset seeds 1000000 .. {999_999 + final_n}, "
        "the same episodes for every algorithm and seed); then the mean of those over seeds "
        "± their standard error (sample standard deviation with n − 1, divided by √n; "
        '"n/a" with a single seed). **Bold**: the best of ours in the row. *optimal*: the '
        "exact planner's mean return on the same evaluation episodes.",
        "",
        f"- Budget: {sweep.budget()}; profile `{sweep.profile}`. Table I: "
        f"{PAPER_STEPS:,} steps, {PAPER_SEEDS} seeds, the paper's public code (the "
        "uncorrected environment of `docs/paper-spec.md` section 7), so its numbers are "
        "beside ours for orientation, not for a like-for-like comparison.",
        f"- Runs: {finished} of {total} finished.",
    ]
    for key, text in (
        ("run_command", "Command (runs)"),
        ("report_command", "Command (this report)"),
        ("date", "Date"),
        ("machine", "Machine"),
        ("wall", "Time"),
        ("versions", "Versions"),
    ):
        if labels.get(key):
            out.append(f"- {text}: {labels[key]}")
    missing = [
        f"{c.config}/{c.algo} seed{'s' if len(c.missing) > 1 else ''} "
        + ", ".join(str(s) for s in c.missing)
        for c in cells
        if c.missing
    ]
    if missing:
        shown = "; ".join(missing[:12])
        if len(missing) > 12:
            shown += f"; and {len(missing) - 12} more"
        out.append(f"- Missing runs (not in the means): {shown}.")
    for problem in problems:
        out.append(f"- Unusable result file: {problem}")
    out += ["", *return_table(sweep, cells), ""]
    notes = []
    if "double_dqn" in sweep.algos:
        notes.append(
            'The paper\'s "DQN" column was a double DQN and its "DDQN" a dueling double DQN '
            "(`docs/paper-spec.md` section 7, item 10), so both stand beside our double DQN, "
            "the closest algorithm we have (ours has no dueling head)."
        )
    if "dqn" in sweep.algos:
        notes.append("Our DQN is plain (vanilla) DQN, which the paper's code did not run.")
    if "maskable_ppo" in sweep.algos:
        notes.append("MaskablePPO (PPO with the blocked-move mask) is not in the paper.")
    if any(c in SIGN_FIXED for c in sweep.configs) and "ppo" in sweep.algos:
        notes.append('\\* printed as "140.18" in the paper; the minus sign was lost.')
    if notes:
        out += [" ".join(notes), ""]
    out += [
        "Success rate (mean over seeds of the final evaluation's success rate) and gap to the "
        "optimum (optimal − ours, in return units and in percent of |optimal|):",
        "",
        *success_gap_table(sweep, cells),
        "",
        "Mean return of the last 100 training episodes (exploration on), mean ± s.e. over "
        'seeds: the literal reading of Table I\'s caption ("in the last 100 episodes"):',
        "",
        *training_table(sweep, cells),
        "",
    ]
    if plots:
        out += [
            "Learning curves (as the paper's Fig. 7): the greedy policy's mean return over "
            f"{sweep.eval_episodes} evaluation episodes every {sweep.eval_every:,} steps, mean "
            "over seeds with a ± s.e. band; dashed: the optimal return.",
            "",
        ]
        out += [f"![{Path(p).stem}]({p})" for p in plots]
        out.append("")
    return "\n".join(out)


def write_summary(path: Path, sweep: Sweep, cells: Sequence[Cell]) -> None:
    from multicrane.benchmark.sweep import write_atomic

    write_atomic(path, json.dumps(summary(sweep, cells), indent=1))


def versions_label(results: Results) -> str:
    """The package versions of the runs (one set, or 'mixed: ...' listing each)."""
    seen: dict[str, set[str]] = {}
    python: set[str] = set()
    for per_seed in results.values():
        for result in per_seed.values():
            if not result:
                continue
            for name, version in (result.get("versions") or {}).items():
                seen.setdefault(name, set()).add(str(version))
            if result.get("python"):
                python.add(str(result["python"]))
    if not seen:
        return ""
    parts = [f"{name} {'/'.join(sorted(v))}" for name, v in seen.items()]
    if python:
        parts.insert(0, f"Python {'/'.join(sorted(python))}")
    return ", ".join(parts)


def compute_label(results: Results) -> str:
    """Total training and evaluation time of the finished runs (CPU-process seconds)."""
    seconds = 0.0
    runs = 0
    for per_seed in results.values():
        for result in per_seed.values():
            if result:
                runs += 1
                seconds += float(result.get("train_seconds") or 0.0)
                seconds += float(result.get("eval_seconds") or 0.0)
    if not runs:
        return ""
    return f"{seconds / 3600:.2f} process-hours of training and final evaluation over {runs} runs"
