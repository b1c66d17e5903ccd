"""The comparison commands' plots: per-episode strips with the mean's interval, learning curves.

``multicrane evaluate``, ``seed-table``, ``compare-planners`` and ``uncertainty`` (``--plot
FILE.png``) and ``tools/marl_curve.py`` draw through ``write_figure``;
``multicrane.reports.comparison_data`` turns each command's results into the panels below.

- A ``StripPanel`` has a column (``Strip``) per policy (or per level, or the lower bound):
  every episode's value (makespan or return) a dot, jittered sideways; the mean the table
  prints as a black bar with its Student-t 95 % interval (``multicrane.stats.ci95``); for a
  learned policy pooled over training seeds, each seed's mean as a diamond (the interval is
  then over seeds, as in ``multicrane seed-table``). Episodes without a value (not finished)
  are counted at the top of their column (``done/episodes``, in red). Columns may stand in
  clusters (crane counts, policies), coloured by ``kind`` with a legend.
- A ``CurvePanel`` has a line per run of each ``Curves`` group (its evaluations during
  training, against wall time or steps); a group of several runs (training seeds) adds their
  mean, thick, with the 95 % interval over runs as a band. A point where a run did not finish
  every evaluation episode has no value: a red cross at the top.

matplotlib (the ``bench`` extra) is imported only when drawing (``require_matplotlib``),
through its object API with the Agg canvas: no display, no pyplot state.
"""

from __future__ import annotations

import statistics
import textwrap
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from multicrane.stats import ci95

BOUND = "lower bound"  # the kind of a bound's column (drawn in black)
JITTER = 0.3  # the dots' sideways spread, in column widths


@dataclass
class Strip:
    """One column: the per-episode values of a policy (one list per training seed)."""

    label: str
    seeds: list[list[float | None]]  # per training seed (one for a planner), per episode
    mean: float | None  # the table's mean (over seeds' means for a pooled learned policy)
    interval: tuple[float, float] | None  # its 95 % interval
    cluster: str = ""  # columns of one cluster stand together under its name
    kind: str = ""  # the colour key (default: the label)

    @property
    def values(self) -> list[float]:
        """Every episode's value (those that have one), seed after seed."""
        return [v for seed in self.seeds for v in seed if v is not None]

    @property
    def episodes(self) -> int:
        return sum(len(seed) for seed in self.seeds)

    @property
    def seed_means(self) -> list[float]:
        """Each training seed's mean (empty for a column of one seed)."""
        if len(self.seeds) < 2:
            return []
        done = [[v for v in seed if v is not None] for seed in self.seeds]
        return [statistics.fmean(d) for d in done if d]


def strip(label: str, values: list[float | None], **where) -> Strip:
    """A column of one seed's episodes: the mean and interval over its values."""
    done = [float(v) for v in values if v is not None]
    mean = statistics.fmean(done) if done else None
    return Strip(label, [list(values)], mean, ci95(done), **where)


@dataclass
class StripPanel:
    title: str
    strips: list[Strip]
    ylabel: str


@dataclass
class Curves:
    """Runs of one policy (training seeds): per run, (x, y) per evaluation (y None: not
    every evaluation episode finished)."""

    label: str
    runs: list[list[tuple[float, float | None]]]


@dataclass
class CurvePanel:
    title: str
    groups: list[Curves]
    xlabel: str
    ylabel: str
    lines: list[tuple[str, float]] = field(default_factory=list)  # reference lines
    ymax: float | None = None  # the y axis's top, its bottom the lowest point (None: automatic)


def require_matplotlib():
    """matplotlib, or an ``ImportError`` that the command line turns into one line naming the
    ``bench`` extra."""
    import matplotlib

    return matplotlib


def write_figure(panels: list, path: str | Path, title: str | None = None) -> Path:
    """Draw ``panels`` (``StripPanel``, ``CurvePanel``) side by side, up to three a row, and
    write the PNG to ``path``; returns it."""
    require_matplotlib()
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    if not panels:
        raise ValueError("nothing to plot")
    cols = min(len(panels), 3)
    rows = -(-len(panels) // cols)
    widest = max(_width(p) for p in panels)
    fig = Figure(figsize=(widest * cols, 3.4 * rows + 0.4), layout="constrained")
    FigureCanvasAgg(fig)
    colours = _colours(panels)
    for i, panel in enumerate(panels):
        ax = fig.add_subplot(rows, cols, i + 1)
        if isinstance(panel, StripPanel):
            _draw_strips(ax, panel, colours)
        else:
            _draw_curves(ax, panel, colours)
    if title:
        fig.suptitle(textwrap.fill(title, width=60 * cols), fontsize="medium")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    return path


def _width(panel) -> float:
    """A panel's width in inches: room for each column's label, or for a cluster's and the
    legend beside it."""
    if not isinstance(panel, StripPanel):
        return 4.6
    if any(s.cluster for s in panel.strips):
        return min(max(4.0, 0.35 * len(panel.strips) + 2.2), 8.0)
    return min(max(3.6, 0.75 * len(panel.strips) + 1.4), 9.0)


def _colours(panels: list) -> dict[str, str]:
    """A colour per kind of column or curve group, in order of first appearance."""
    kinds: dict[str, None] = {}
    for panel in panels:
        if isinstance(panel, StripPanel):
            kinds.update(dict.fromkeys(s.kind or s.label for s in panel.strips))
        else:
            kinds.update(dict.fromkeys(g.label for g in panel.groups))
    kinds.pop(BOUND, None)
    out = {k: f"C{i % 10}" for i, k in enumerate(kinds)}
    out[BOUND] = "black"
    return out


def positions(strips: list[Strip]) -> list[float]:
    """Each column's x: one apart, with a gap of one between clusters."""
    xs, x = [], 0.0
    for i, s in enumerate(strips):
        if i and s.cluster != strips[i - 1].cluster:
            x += 1.0
        xs.append(x)
        x += 1.0
    return xs


def _draw_strips(ax, panel: StripPanel, colours: dict[str, str]) -> None:
    rng = np.random.default_rng(0)  # the same jitter every time
    xs = positions(panel.strips)
    for x, s in zip(xs, panel.strips, strict=True):
        colour = colours[s.kind or s.label]
        marker = "_" if s.kind == BOUND else "o"
        for seed in s.seeds:
            ys = [v for v in seed if v is not None]
            jitter = rng.uniform(-JITTER / 2, JITTER / 2, len(ys))
            ax.scatter(x + jitter, ys, s=16, color=colour, alpha=0.6, marker=marker,
                       linewidths=1.2 if s.kind == BOUND else 0, zorder=5)  # fmt: skip
        if s.seed_means:
            ax.scatter([x + JITTER] * len(s.seed_means), s.seed_means, s=30, marker="D",
                       color=colour, edgecolor="black", linewidths=0.6, zorder=6)  # fmt: skip
        if s.mean is not None:
            low, high = s.interval or (s.mean, s.mean)
            ax.errorbar([x], [s.mean], yerr=[[s.mean - low], [high - s.mean]], fmt="none",
                        ecolor="black", elinewidth=1.2, capsize=4, zorder=4)  # fmt: skip
            ax.hlines(s.mean, x - 0.3, x + 0.3, color="black", linewidth=2, zorder=4)
        if len(s.values) < s.episodes:
            ax.annotate(f"{len(s.values)}/{s.episodes}\ndone", (x, 1.0), ha="center", va="top",
                        xycoords=ax.get_xaxis_transform(), fontsize=7, color="red")  # fmt: skip
    _strip_axes(ax, panel, xs, colours)


def _strip_axes(ax, panel: StripPanel, xs: list[float], colours: dict[str, str]) -> None:
    """Ticks (per column, or per cluster with a legend of the kinds), labels and title."""
    strips = panel.strips
    if any(s.cluster for s in strips):
        clusters = list(dict.fromkeys(s.cluster for s in strips))
        centres = [
            statistics.fmean(x for x, s in zip(xs, strips, strict=True) if s.cluster == c)
            for c in clusters
        ]
        labels = [textwrap.fill(c, 16, break_long_words=False) for c in clusters]
        ax.set_xticks(centres, labels, fontsize=8)
        kinds = list(dict.fromkeys(s.kind or s.label for s in strips))
        handles = [
            ax.scatter([], [], color=colours[k], marker="_" if k == BOUND else "o", label=k)
            for k in kinds
        ]
        ax.legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    else:
        labels = [textwrap.fill(s.label, 10, break_long_words=False) for s in strips]
        ax.set_xticks(xs, labels, fontsize=8)
    ax.set_xlim(min(xs) - 0.7, max(xs) + 0.7)
    ax.set_ylabel(panel.ylabel)
    ax.set_title(panel.title, fontsize=10)
    ax.grid(axis="y", alpha=0.3)


def _draw_curves(ax, panel: CurvePanel, colours: dict[str, str]) -> None:
    tops = [y for g in panel.groups for run in g.runs for _, y in run if y is not None]
    top = max(tops) * 1.03 if tops else 1.0
    stalls = []
    for g in panel.groups:
        colour = colours[g.label]
        many = len(g.runs) > 1
        for run in g.runs:
            ax.plot([x for x, _ in run], [np.nan if y is None else y for _, y in run],
                    color=colour, alpha=0.3 if many else 1.0, linewidth=1,
                    marker=None if many else "o", markersize=3,
                    label=None if many else g.label)  # fmt: skip
            stalls += [x for x, y in run if y is None]
        if many:
            xs, mean, low, high = curve_mean(g.runs)
            ax.plot(xs, mean, color=colour, marker="o", markersize=3, linewidth=2,
                    label=f"{g.label}, mean of {len(g.runs)} runs")  # fmt: skip
            ax.fill_between(xs, low, high, color=colour, alpha=0.15)
    if stalls:
        ax.scatter(stalls, [top] * len(stalls), marker="x", color="red", zorder=3,
                   label="not every evaluation episode finished")  # fmt: skip
    for i, (label, value) in enumerate(panel.lines):
        ax.axhline(value, linestyle="--", linewidth=1, color="black" if i == 0 else f"C{i + 5}",
                   label=f"{label} ({value:g})")  # fmt: skip
    ax.set_xlabel(panel.xlabel)
    ax.set_ylabel(panel.ylabel)
    ax.set_title(panel.title, fontsize=10)
    if panel.ymax is not None:  # a band wider than the points (a run that collapsed) is cut
        ax.set_ylim(min(tops, default=0.0) * 0.97, panel.ymax)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)


def curve_mean(runs: list[list[tuple[float, float | None]]]):
    """(x, mean, low, high) at each evaluation every run reached: the mean x (runs evaluate
    at the same steps, not at the same seconds) and the mean of the runs that have a value,
    with its 95 % interval (the mean itself where it has none)."""
    n = min(len(run) for run in runs)
    xs, mean, low, high = [], [], [], []
    for i in range(n):
        ys = [run[i][1] for run in runs if run[i][1] is not None]
        if not ys:
            continue
        m = statistics.fmean(ys)
        lo, hi = ci95(ys) or (m, m)
        xs.append(statistics.fmean(run[i][0] for run in runs))
        mean.append(m)
        low.append(lo)
        high.append(hi)
    return xs, mean, low, high


__all__ = ["BOUND", "CurvePanel", "Curves", "Strip", "StripPanel", "curve_mean", "positions",
           "require_matplotlib", "strip", "write_figure"]  # fmt: skip
