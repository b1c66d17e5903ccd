"""What each comparison command plots: its results as the panels of ``comparison_plot``.

The per-episode values are those the command's table summarises, and each column's mean and
interval the table's: ``evaluate_panels`` (``multicrane evaluate``: makespans, or returns in
the paper mode beside the exact planner's), ``seed_table_panels`` (the learned runs pooled
over training seeds, ``multicrane.reports.seed_table``), ``planner_panels`` (``multicrane
compare-planners``, ``multicrane.reports.planners``) and ``uncertainty_panels`` (the levels
side by side per policy, ``multicrane.reports.uncertainty``); one panel per scenario, with
the per-episode lower bound where the command has one. ``curve_panel`` reads the
evaluations that training runs made on the way (``run_curve``: ``result.json``, or the
checkpoint of a run still going) against training wall time.
"""

from __future__ import annotations

import json
import pickle
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path

from multicrane.reports.comparison_plot import BOUND, CurvePanel, Curves, Strip, StripPanel, strip
from multicrane.reports.planners import Results
from multicrane.reports.seed_table import Entry
from multicrane.reports.uncertainty import Bound, Cell

MAKESPAN = "makespan (simulated steps)"


def _scenarios(episodes: Sequence[Mapping]) -> list[str]:
    return list(dict.fromkeys(e["scenario"] for e in episodes))


def evaluate_panels(rows: Sequence[Mapping], paper: bool) -> list[StripPanel]:
    """``multicrane evaluate``'s rows: per scenario (the sites of a set), a column per policy
    of its episodes' makespans (returns in the paper mode, beside the exact planner's return
    on each episode, ``optimal_return``, unless the exact planner is one of the rows)."""
    key = "return" if paper else "makespan"
    panels = []
    for name in _scenarios(rows[0]["episodes"]):
        strips = []
        for row in rows:
            eps = [e for e in row["episodes"] if e["scenario"] == name]
            strips.append(strip(row["policy"], [e[key] for e in eps]))
        first = [e for e in rows[0]["episodes"] if e["scenario"] == name]
        played = any(row["policy"] == "optimal" for row in rows)  # the same values
        if paper and not played and all("optimal_return" in e for e in first):
            strips.append(strip("optimal", [e["optimal_return"] for e in first], kind=BOUND))
        panels.append(StripPanel(name, strips, "return" if paper else MAKESPAN))
    return panels


def seed_table_panels(
    entries: Sequence[Entry], scenarios: Sequence[str], bounds: Sequence[int] | None = None
) -> list[StripPanel]:
    """``multicrane seed-table``'s entries (``scenarios``: each episode's scenario): per
    scenario a column per entry, a learned one with its training seeds' episodes and means,
    and the episodes' lower bounds. Each column's mean and interval are the entry's (the
    table's, computed on that scenario's episodes)."""
    panels = []
    for name in dict.fromkeys(scenarios):
        idx = [i for i, s in enumerate(scenarios) if s == name]
        strips = []
        for e in entries:
            part = Entry(e.name, e.seeds, [[spans[i] for i in idx] for spans in e.makespans],
                         e.learned)  # fmt: skip
            label = e.name + (f" ({len(e.seeds)} seeds)" if len(e.seeds) > 1 else "")
            strips.append(Strip(label, part.makespans, part.mean, part.ci, kind=e.name))
        if bounds:
            strips.append(strip("bound", [bounds[i] for i in idx], kind=BOUND))
        panels.append(StripPanel(name, strips, MAKESPAN))
    return panels


def planner_panels(results: Results) -> list[StripPanel]:
    """``multicrane compare-planners``: per scenario, a cluster per crane count with a
    column per policy (its episodes' makespans) and the episodes' lower bounds."""
    panels = []
    for name in results.setup.scenarios:
        strips = []
        for n in results.setup.cranes:
            cluster = f"{n} crane{'s' if n > 1 else ''}"
            for policy in results.setup.policies:
                cell = results.cells.get((name, n, policy))
                if cell is not None:
                    spans = [r["makespan"] for r in cell.results]
                    strips.append(strip(policy, spans, cluster=cluster))
            bound = results.bounds.get((name, n))
            if bound is not None:
                strips.append(strip("bound", bound.values, cluster=cluster, kind=BOUND))
        if strips:
            panels.append(StripPanel(name, strips, MAKESPAN))
    return panels


def uncertainty_panels(cells: Sequence[Cell], bounds: Sequence[Bound]) -> list[StripPanel]:
    """``multicrane uncertainty``: per scenario and crane count, a cluster per policy with
    its levels side by side (the episodes' makespans), and the undisturbed site's bounds."""
    bound_of = {(b.scenario, b.n_cranes): b for b in bounds}
    policies = list(dict.fromkeys(c.policy for c in cells))
    levels = list(dict.fromkeys(c.level for c in cells))
    order = sorted(cells, key=lambda c: (policies.index(c.policy), levels.index(c.level)))
    panels = []
    for scenario, n in dict.fromkeys((c.scenario, c.n_cranes) for c in cells):
        strips = [
            Strip(c.level, [list(c.makespans)], c.mean, c.ci, cluster=c.policy, kind=c.level)
            for c in order
            if (c.scenario, c.n_cranes) == (scenario, n)
        ]
        b = bound_of.get((scenario, n))
        if b is not None:
            strips.append(strip("undisturbed", b.values, cluster="bound", kind=BOUND))
        panels.append(StripPanel(f"{scenario} ({n} cranes)", strips, MAKESPAN))
    return panels


def run_curve(run_dir: str | Path) -> list[dict]:
    """The evaluations a training run made on the way (``multicrane.training.trainer``): from
    its ``result.json``, or, for a run still going, its checkpoint's progress. A path to a
    model file stands for its directory."""
    path = Path(run_dir)
    path = path.parent if path.suffix == ".zip" else path
    result = path / "result.json"
    if result.exists():
        return json.loads(result.read_text())["curve"]
    with open(path / "checkpoint" / "state.pkl", "rb") as f:  # our own checkpoint
        return pickle.load(f)["progress"]["curve"]


def run_curves(
    groups: Mapping[str, Sequence[str | Path]], say: Callable[[str], None] = print
) -> dict[str, list[list[dict]]]:
    """``run_curve`` of each group's runs; a group with a run that cannot be read (moved,
    never evaluated) is left out, and ``say`` says so."""
    out = {}
    for label, runs in groups.items():
        try:
            out[label] = [run_curve(r) for r in runs]
        except (OSError, KeyError, pickle.UnpicklingError) as exc:
            say(f"learning curves of {label}: left out ({exc})")
    return out


def curve_panel(
    curves: Mapping[str, Sequence[Sequence[Mapping]]], paper: bool, against: str = "time",
    title: str = "learning curves",
) -> CurvePanel:  # fmt: skip
    """Each group's runs (``run_curves``: a policy's training seeds) against training wall
    time (``against="time"``: each point's ``seconds``, imitation excluded; steps where a
    run did not record them) or timesteps (``"steps"``): the mean return of the evaluation
    episodes in the paper mode, else their mean makespan (none where not all finished)."""
    points = [p for runs in curves.values() for run in runs for p in run]
    timed = against == "time" and all("seconds" in p for p in points)
    x = "seconds" if timed else "step"

    def value(p: Mapping) -> float | None:
        if paper:
            return p["return_mean"]
        return p["steps_mean"] if p.get("success_rate", 1.0) >= 1.0 else None

    out = [
        Curves(label, [[(p[x], value(p)) for p in run] for run in runs])
        for label, runs in curves.items()
    ]
    xlabel = "training wall time (s)" if timed else "timesteps trained"
    if not timed and not paper:
        xlabel += " (crane decisions)"
    if against == "time" and not timed:
        xlabel += ": no wall time recorded"
    ylabel = "mean evaluation return" if paper else "mean evaluation makespan"
    return CurvePanel(title, out, xlabel, ylabel)


__all__ = ["MAKESPAN", "curve_panel", "evaluate_panels", "planner_panels", "run_curve",
           "run_curves", "seed_table_panels", "uncertainty_panels"]  # fmt: skip
