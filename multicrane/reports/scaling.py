"""Scaling costs: load, reset, step and planner time of generated sites of growing size.

``measure(components, cranes, planner)`` builds one generated site (``SHAPES``: hall
buildings of 3 to 490 components, fixed starts in a yard on one side, no obstacles, own
targets), writes it to a TOML file and times, with ``time.perf_counter``:

- ``load_s``: ``load_scenario`` of that file (the strict loader, solvability included);
- ``reset_s``: the fastest of three ``env.reset(seed=...)`` of ``parallel_env`` with the
  given number of cranes (construction excluded);
- ``step_ms`` and ``step_ms_per_crane``: the mean ``env.step`` time of a joint step under
  random legal actions (drawn from the action masks, as a masked policy would, by
  ``multicrane.episodes.random_actions``; the draws are not timed), and that divided by the
  cranes;
- ``plan_ms`` and ``plan_ms_max``: the mean and slowest call of ``planner(env, seed)`` (a
  policy handed in by the caller: this module never imports ``policies``) over the first
  ``decisions`` decisions of the episode from ``reset(seed=0)``.

``fit_growth(rows, key)`` fits ``cost = a * components**b * cranes**c`` by least squares on
the logarithms and returns ``(b, c)``. Sites with random starts stop earlier than 490
components: their yard is three times as deep, and a 490-component random-start hall
(165 x 133 x 12 cells) exceeds ``MAX_SITE_CELLS``; fixed starts keep every size in range.
"""

from __future__ import annotations

import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from multicrane.episodes.random_actions import random_legal_policy
from multicrane.episodes.rollout import Stopwatch, play
from multicrane.tables import markdown_table

# components -> (bays_x, bays_y, storeys) of a hall with span 4 and columns 4 cells high.
SHAPES: dict[int, tuple[int, int, int]] = {
    3: (1, 0, 1),
    8: (1, 1, 1),
    21: (2, 2, 1),
    40: (3, 3, 1),
    121: (4, 8, 1),
    242: (4, 8, 2),
    490: (10, 7, 2),
}
CRANES = (1, 2, 4, 8, 16)
QUICK_COMPONENTS = (3, 21, 121)
QUICK_CRANES = (1, 4, 16)
COSTS = ("load_s", "reset_s", "step_ms_per_crane", "plan_ms")


def site(components: int):
    """The generated scenario of ``SHAPES[components]`` (cranes are chosen at the env)."""
    from multicrane.scenario.generator import generate

    if components not in SHAPES:
        raise ValueError(f"no scaling site of {components} components; sizes: {list(SHAPES)}")
    nx, ny, storeys = SHAPES[components]
    return generate(
        "hall", 0, bays_x=nx, bays_y=ny, storeys=storeys, span=4, column_height=4, cranes=1,
        yard="one", obstacles=0, interchangeable=False, random_start=False,
    )  # fmt: skip


def measure(
    components: int,
    cranes: int,
    planner: Callable[[Any, int], Callable] | None,
    steps: int = 200,
    decisions: int = 100,
) -> dict[str, Any]:
    """The costs of the module doc for one (components, cranes) point of the grid."""
    import multicrane
    from multicrane.scenario.loader import load_scenario
    from multicrane.scenario.writer import to_toml

    scenario = site(components)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "site.toml"
        path.write_text(to_toml(scenario))
        t = time.perf_counter()
        scenario = load_scenario(str(path))
        load_s = time.perf_counter() - t
    env = multicrane.parallel_env(scenario, n_cranes=cranes)
    resets = []
    for seed in range(3):
        t = time.perf_counter()
        env.reset(seed=seed)
        resets.append(time.perf_counter() - t)
    step_s = _step_seconds(env, steps)
    row: dict[str, Any] = {
        "components": scenario.n_components,
        "cranes": cranes,
        "cells": int(np.prod(scenario.size)),
        "load_s": load_s,
        "reset_s": min(resets),
        "step_ms": 1e3 * step_s,
        "step_ms_per_crane": 1e3 * step_s / cranes,
    }
    if planner is not None:
        calls = _planner_seconds(env, planner, decisions)
        row["plan_ms"] = 1e3 * float(np.mean(calls))
        row["plan_ms_max"] = 1e3 * max(calls)
    return row


def _step_seconds(env, steps: int) -> float:
    """Mean seconds of ``env.step`` alone over ``steps`` joint steps of random legal actions
    from ``reset(seed=0)`` (neither the draws nor the resets counted)."""
    watch = Stopwatch()
    policy = random_legal_policy(env.possible_agents, np.random.default_rng(0))
    play(env, policy, 0, steps=steps, repeat=True, step_watch=watch)
    return sum(watch.seconds) / steps


def _planner_seconds(env, planner: Callable, decisions: int) -> list[float]:
    """Seconds of each planner call over the first ``decisions`` of one episode (seed 0)."""
    watch = Stopwatch()
    play(env, watch.timing(planner(env, 0)), 0, steps=decisions)
    return watch.seconds


def grid(full: bool) -> list[tuple[int, int]]:
    """The (components, cranes) points: the quick grid, or every size x every crane count."""
    comps, cranes = (tuple(SHAPES), CRANES) if full else (QUICK_COMPONENTS, QUICK_CRANES)
    return [(n, k) for n in comps for k in cranes]


def fit_growth(rows: list[dict[str, Any]], key: str) -> tuple[float, float]:
    """Exponents (b, c) of ``key ~ a * components**b * cranes**c`` (least squares on logs);
    a crane count that never varies gets c = 0."""
    n = np.log([r["components"] for r in rows])
    k = np.log([r["cranes"] for r in rows])
    y = np.log([max(r[key], 1e-9) for r in rows])
    columns = [np.ones_like(n), n] + ([k] if np.ptp(k) > 0 else [])
    coef = np.linalg.lstsq(np.stack(columns, axis=1), y, rcond=None)[0]
    return float(coef[1]), float(coef[2]) if len(coef) > 2 else 0.0


def table(rows: list[dict[str, Any]]) -> str:
    """The rows as a markdown table, then one line per cost with its fitted exponents."""
    head = ["components", "cranes", "cells", "load s", "reset ms", "step ms", "step ms/crane",
            "plan ms", "plan max ms"]  # fmt: skip
    lines = markdown_table(head, ([
        f"{r['components']}", f"{r['cranes']}", f"{r['cells']}", f"{r['load_s']:.3f}",
        f"{1e3 * r['reset_s']:.1f}", f"{r['step_ms']:.2f}", f"{r['step_ms_per_crane']:.3f}",
        f"{r.get('plan_ms', float('nan')):.2f}", f"{r.get('plan_ms_max', float('nan')):.1f}",
    ] for r in rows), align="")  # fmt: skip
    lines.append("")
    for key in COSTS:
        if all(key in r for r in rows):
            b, c = fit_growth(rows, key)
            lines.append(f"- `{key}` ~ components^{b:.2f} x cranes^{c:.2f}")
    return "\n".join(lines)


def plot(rows: list[dict[str, Any]], path: str) -> None:
    """A log-log PNG: one panel per cost against components, one line per crane count
    (needs matplotlib: the ``bench`` extra, ``pip install 'multicrane[bench]'``)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    costs = [key for key in COSTS if all(key in r for r in rows)]
    fig, axes = plt.subplots(1, len(costs), figsize=(4 * len(costs), 3.6), squeeze=False)
    for ax, key in zip(axes[0], costs, strict=True):
        for k in sorted({r["cranes"] for r in rows}):
            pts = sorted((r["components"], r[key]) for r in rows if r["cranes"] == k)
            ax.loglog(*zip(*pts, strict=True), marker="o", label=f"{k} cranes")
        b, c = fit_growth(rows, key)
        ax.set_title(f"{key}\n~ N^{b:.2f} x K^{c:.2f}", fontsize=10)
        ax.set_xlabel("components N")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
