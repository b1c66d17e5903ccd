"""The uncertainty benchmark's plot: makespan per disruption level and policy, as a PNG file.

One panel per scenario and crane count; per level a group of bars (one per policy: mean
makespan of the completed episodes, 95 % confidence interval as error bars, completion rate
written above when below 100 %) and a dashed line at the undisturbed site's lower bound.
matplotlib (the ``bench`` extra) is imported only here, through its object API with the Agg
canvas.
"""

from __future__ import annotations

from pathlib import Path

from multicrane.reports.uncertainty import Bound, Cell


def plot(cells: list[Cell], bounds: list[Bound], path: str | Path) -> Path:
    """Write the plot to ``path`` (PNG) and return it."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError:
        raise RuntimeError("the plot needs matplotlib: pip install 'multicrane[bench]'") from None
    scenarios = list(dict.fromkeys((c.scenario, c.n_cranes) for c in cells))
    levels = list(dict.fromkeys(c.level for c in cells))
    names = list(dict.fromkeys(c.policy for c in cells))
    by = {((c.scenario, c.n_cranes), c.level, c.policy): c for c in cells}
    bound_of = {(b.scenario, b.n_cranes): b for b in bounds}
    fig = Figure(figsize=(4.2 * len(scenarios), 3.6))
    FigureCanvasAgg(fig)
    width = 0.8 / max(len(names), 1)
    for i, scenario in enumerate(scenarios):
        ax = fig.add_subplot(1, len(scenarios), i + 1)
        for j, name in enumerate(names):
            xs, ys, lo, hi = [], [], [], []
            for k, level in enumerate(levels):
                c = by.get((scenario, level, name))
                if c is None or c.mean is None:
                    continue
                ci = c.ci or (c.mean, c.mean)
                xs.append(k + (j - (len(names) - 1) / 2) * width)
                ys.append(c.mean)
                lo.append(c.mean - ci[0])
                hi.append(ci[1] - c.mean)
                if c.completion < 1:
                    ax.annotate(f"{c.completion:.0%}", (xs[-1], ci[1]), ha="center",
                                va="bottom", fontsize=7)  # fmt: skip
            ax.bar(xs, ys, width, yerr=[lo, hi], capsize=2, label=name)
        b = bound_of.get(scenario)
        if b is not None:
            ax.axhline(b.mean, color="black", linestyle="--", linewidth=1,
                       label="bound (undisturbed)")  # fmt: skip
        ax.set_xticks(range(len(levels)), levels)
        ax.set_xlabel("disruption level")
        ax.set_title(f"{scenario[0]} ({scenario[1]} cranes)", fontsize=10)
        if i == 0:
            ax.set_ylabel("makespan (steps)")
            ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    return path


__all__ = ["plot"]
