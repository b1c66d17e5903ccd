"""Learning curves like the paper's Fig. 7, as PNG files (needs matplotlib: the ``bench``
extra, ``pip install 'multicrane[bench]'``).

One figure per environment, one panel per configuration (its scenarios), one line per
algorithm: the greedy policy's mean evaluation return (a curve point of ``result.json``)
against environment steps, averaged over seeds, with a band of +- the standard error over
seeds; a dashed line at the exact planner's return on the same evaluation episodes.
matplotlib is imported only here, through its object API with the Agg canvas, so no
display and no global pyplot state are involved.
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from multicrane.benchmark.aggregate import LABELS, Results
from multicrane.benchmark.profiles import Sweep
from multicrane.stats import mean_sem

COLORS = {
    "dqn": "tab:blue",
    "double_dqn": "tab:orange",
    "a2c": "tab:green",
    "ppo": "tab:red",
    "maskable_ppo": "tab:purple",
    "lean_ppo": "tab:brown",
}


def import_matplotlib():
    try:
        import matplotlib
    except ImportError:
        raise RuntimeError(
            "plots need matplotlib: pip install 'multicrane[bench]' (or --no-plots)"
        ) from None
    return matplotlib


def curve_band(curves: Sequence[Sequence[dict]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(steps, mean, s.e.) over seeds of ``return_mean`` curves. Seeds of one algorithm
    evaluate at the same steps; should they not, each curve is interpolated onto the steps
    of the first over the range that all cover. The s.e. is 0 with one seed (no band)."""
    curves = [c for c in curves if c]
    if not curves:
        return np.array([]), np.array([]), np.array([])
    xs = [np.array([p["step"] for p in c], dtype=float) for c in curves]
    ys = [np.array([p["return_mean"] for p in c], dtype=float) for c in curves]
    lo, hi = max(x[0] for x in xs), min(x[-1] for x in xs)
    grid = xs[0][(xs[0] >= lo) & (xs[0] <= hi)]
    table = np.array([np.interp(grid, x, y) for x, y in zip(xs, ys, strict=True)])
    mean = table.mean(axis=0)
    sem = np.zeros_like(mean)
    if len(table) > 1:
        sem = np.array([mean_sem(col)[1] for col in table.T])
    return grid, mean, sem


def optimal_return(per_seed: dict[int, dict | None]) -> float | None:
    values = [r["final"]["optimal_mean"] for r in per_seed.values() if r]
    values = [v for v in values if v is not None]
    return float(np.mean(values)) if values else None


def environment_figure(sweep: Sweep, results: Results, env: str, path: Path, title: str) -> Path:
    """The panels of one environment (``"E1"``) in one PNG."""
    import_matplotlib()
    from matplotlib.figure import Figure
    from matplotlib.ticker import FuncFormatter

    configs = [c for c in sweep.configs if c.startswith(env)]
    cols = 2 if len(configs) > 1 else 1
    rows = (len(configs) + cols - 1) // cols
    fig = Figure(figsize=(5.2 * cols, 3.6 * rows + 0.8), layout="constrained")
    axes = np.atleast_1d(fig.subplots(rows, cols, squeeze=False).ravel())
    handles = {}
    for ax, config in zip(axes, configs, strict=False):
        optimal = None
        for algo in sweep.algos:
            per_seed = results.get((config, algo), {})
            curves = [r["curve"] for r in per_seed.values() if r]
            steps, mean, sem = curve_band(curves)
            if optimal is None:
                optimal = optimal_return(per_seed)
            if not len(steps):
                continue
            (line,) = ax.plot(steps, mean, color=COLORS.get(algo), lw=1.6)
            ax.fill_between(steps, mean - sem, mean + sem, color=COLORS.get(algo), alpha=0.2)
            handles[algo] = (line, LABELS[algo])
        if optimal is not None:
            ref = ax.axhline(optimal, color="black", ls="--", lw=1.0)
            handles["optimal"] = (ref, "optimal")
        ax.set_title(config)
        ax.set_xlabel("environment steps")
        ax.set_ylabel(f"return (greedy, {sweep.eval_episodes} episodes)")
        ax.grid(alpha=0.3)
        ax.xaxis.set_major_formatter(FuncFormatter(_steps_label))
    for ax in axes[len(configs) :]:
        ax.set_visible(False)
    if handles:
        order = [k for k in (*sweep.algos, "optimal") if k in handles]
        fig.legend(
            [handles[k][0] for k in order],
            [handles[k][1] for k in order],
            loc="outside lower center",
            ncols=min(len(order), 3 * cols),
            fontsize="small",
        )
    # Wrap long titles (custom sweeps have long names) to the figure's width.
    fig.suptitle(textwrap.fill(title, width=48 * cols), fontsize="medium")
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    return path


def _steps_label(x: float, _pos=None) -> str:
    """Axis steps as 0, 500, 5k, 1.5M."""
    if abs(x) >= 1e6:
        return f"{x / 1e6:g}M"
    if abs(x) >= 1e3:
        return f"{x / 1e3:g}k"
    return f"{x:g}"


def write_plots(sweep: Sweep, results: Results, out_dir: Path, prefix: str) -> list[Path]:
    """One PNG per environment of the sweep: ``<out_dir>/<prefix>-env<k>.png``."""
    paths = []
    for env in dict.fromkeys(c[:2] for c in sweep.configs):
        title = (
            f"Env{env[1]}: {sweep.name} sweep, {sweep.steps:,} steps per run, "
            f"{len(sweep.seeds)} seed{'s' if len(sweep.seeds) != 1 else ''}"
        )
        path = Path(out_dir) / f"{prefix}-env{env[1]}.png"
        paths.append(environment_figure(sweep, results, env, path, title))
    return paths
