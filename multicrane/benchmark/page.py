"""The markdown page of a sweep's results: Table I's metric beside the paper's numbers,
success and gap tables, training returns, labels (command, machine, versions, time) and the
generated section of ``docs/benchmark.md``.
"""

from __future__ import annotations

import statistics
from collections.abc import Mapping, Sequence
from pathlib import Path

from multicrane.benchmark.aggregate import LABELS, Cell, Results
from multicrane.benchmark.profiles import Sweep
from multicrane.benchmark.reference import (
    PAPER_COLUMN,
    PAPER_MEANING,
    PAPER_SEEDS,
    PAPER_STEPS,
    SIGN_FIXED,
    table_i,
)
from multicrane.benchmark.scores import Baseline, score_table
from multicrane.tables import markdown_table


def _num(value: float | None, digits: int = 2) -> str:
    return "n/a" if value is None else f"{value:.{digits}f}"


def _ours(cell: Cell, best: bool) -> str:
    if cell.n == 0:
        return "pending"
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
    return markdown_table(header, rows)


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
            line.append("pending" if rate is None else f"{rate:.0%}")
        for algo in sweep.algos:
            cell = row[algo]
            if cell.gap is None:
                line.append("pending" if cell.n == 0 else "n/a")
            else:
                pct = "" if cell.gap_pct is None else f" ({cell.gap_pct:.0f} %)"
                line.append(f"{cell.gap:.2f}{pct}")
        rows.append(line)
    return markdown_table(header, rows)


def training_table(sweep: Sweep, cells: Sequence[Cell]) -> list[str]:
    header = ["config"] + [LABELS[a] for a in sweep.algos]
    rows = []
    for config, row in _rows(sweep, cells).items():
        line = [config]
        for algo in sweep.algos:
            mean, sem = row[algo].train_return
            line.append("pending" if mean is None else f"{_num(mean)} ± {_num(sem)}")
        rows.append(line)
    return markdown_table(header, rows)


LABELS_SHOWN = (  # (key of ``labels``, its name on the page), in the page's order
    ("run_command", "Command (runs)"),
    ("report_command", "Command (this report)"),
    ("date", "Date"),
    ("machine", "Machine"),
    ("wall", "Time"),
    ("versions", "Versions"),
)

ALGO_NOTES = (  # (algorithm, what to know when reading its column beside Table I)
    ("double_dqn", 'The paper\'s "DQN" column was a double DQN and its "DDQN" a dueling double '
     "DQN (`docs/paper-spec.md` section 7, item 10), so both stand beside our double DQN, "
     "the closest algorithm we have (ours has no dueling head)."),
    ("dqn", "Our DQN is plain (vanilla) DQN, which the paper's code did not run."),
    ("maskable_ppo", "MaskablePPO (PPO with the blocked-move mask) is not in the paper."),
)  # fmt: skip
SIGN_NOTE = '\\* printed as "140.18" in the paper; the minus sign was lost.'


def markdown(
    sweep: Sweep,
    cells: Sequence[Cell],
    labels: Mapping[str, str],
    plots: Sequence[str] = (),
    problems: Sequence[str] = (),
    heading: str = "###",
    baseline: Mapping[str, Baseline] | None = None,
) -> str:
    """The report: how the numbers were made, then the tables and the learning curves.

    ``labels``: ``run_command``, ``report_command``, ``date``, ``machine``, ``versions``,
    ``wall`` (free text, shown when present). ``plots``: image paths relative to the page.
    ``baseline``: each configuration's random and optimal returns on the evaluation
    episodes (``scores.baselines``); with it, the page opens with ``scores.score_table``
    (interval, normalised score, Table I best, targets) and says which cells are pending."""
    out = [f"{heading} Benchmark results: `{sweep.name}` sweep", "", metric_text(sweep), ""]
    out += run_lines(sweep, cells, labels, problems)
    if baseline is not None:
        pending = sum(1 for c in cells if c.n == 0)
        out += [
            "",
            f"Per configuration and algorithm ({pending} of {len(cells)} cells pending):",
            "",
            *score_table(sweep.configs, sweep.algos, cells, baseline),
            "",
            "The same final returns beside every Table I column:",
        ]
    out += ["", *return_table(sweep, cells), ""]
    notes = [note for algo, note in ALGO_NOTES if algo in sweep.algos]
    if any(c in SIGN_FIXED for c in sweep.configs) and "ppo" in sweep.algos:
        notes.append(SIGN_NOTE)
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
    return "\n".join(out + plot_lines(sweep, plots))


def metric_text(sweep: Sweep) -> str:
    """What the numbers are: the final return of each seed, then mean ± s.e. over seeds."""
    seeds = len(sweep.seeds)
    final_n = sweep.final_episodes or sweep.eval_episodes
    return (
        f"Final return, mean ± standard error over {seeds} seed{'s' if seeds != 1 else ''}: "
        'for each seed, `result["final"]["return_mean"]`, the mean return of the trained '
        "policy acting greedily (deterministic actions) over the final evaluation's "
        f"{final_n} episodes (reset seeds 1000000 .. {999_999 + final_n}, "
        "the same episodes for every algorithm and seed); then the mean of those over seeds "
        "± their standard error (sample standard deviation with n − 1, divided by √n; "
        '"n/a" with a single seed). **Bold**: the best of ours in the row. *optimal*: the '
        "exact planner's mean return on the same evaluation episodes."
    )


def run_lines(
    sweep: Sweep, cells: Sequence[Cell], labels: Mapping[str, str], problems: Sequence[str]
) -> list[str]:
    """The list under the metric: budget, runs finished, labels, runs pending, bad files."""
    total = len(sweep.runs())
    out = [
        f"- Budget: {sweep.budget()}; profile `{sweep.profile}`. Table I: "
        f"{PAPER_STEPS:,} steps, {PAPER_SEEDS} seeds, the paper's public code (the "
        "uncorrected environment of `docs/paper-spec.md` section 7), so its numbers are "
        "beside ours for orientation, not for a like-for-like comparison.",
        f"- Runs: {sum(c.n for c in cells)} of {total} finished.",
    ]
    out += [f"- {name}: {labels[key]}" for key, name in LABELS_SHOWN if labels.get(key)]
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
        out.append(f"- Runs without a result yet (pending, not in the means): {shown}.")
    return out + [f"- Unusable result file: {problem}" for problem in problems]


def plot_lines(sweep: Sweep, plots: Sequence[str]) -> list[str]:
    """The learning curves, when there are any, under a line saying what they show."""
    if not plots:
        return []
    return [
        "Learning curves (as the paper's Fig. 7): the greedy policy's mean return over "
        f"{sweep.eval_episodes} evaluation episodes every {sweep.eval_every:,} steps, mean "
        "over seeds with a ± s.e. band; dashed: the optimal return.",
        "",
        *(f"![{Path(p).stem}]({p})" for p in plots),
        "",
    ]


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
