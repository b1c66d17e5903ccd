"""The tables of the planner comparison (``multicrane.reports.planners``): headers and rows.

``multicrane.tables`` lays them out as markdown or plain text.
"""

from __future__ import annotations

from multicrane.reports.planners import LARGE, PLANNERS, Cell, Results

HEAD = [
    "scenario",
    "cranes",
    "greedy makespan",
    "greedy ok",
    "greedy blocked",
    "prioritized makespan",
    "prioritized ok",
    "prioritized blocked",
    "prio vs greedy",
    "random makespan",
    "random ok",
    "optimal (auto) steps",
    "opt+2/comp",
]

TIMING_HEAD = [
    "scenario",
    "cranes",
    "planner",
    "ms per joint decision",
    "ms per crane decision",
    "slowest call (ms)",
]


BOUND_HEAD = [
    "scenario",
    "cranes",
    "lower bound",
    "proven",
    "greedy makespan",
    "greedy gap",
    "prioritized makespan",
    "prioritized gap",
]

TASK_HEAD = [
    "scenario",
    "cranes",
    "task-mode makespan",
    "= motion",
    "decision rounds",
    "ms per round",
    "motion joint steps",
    "ms per joint step",
]


def num(x: float | None, digits: int = 1) -> str:
    return "-" if x is None else f"{x:.{digits}f}"


def cranes(n: int) -> str:
    return f"{n} crane{'s' if n != 1 else ''}"


def _make(cell: Cell | None) -> str:
    """Mean makespan over completed episodes (min-max when they differ)."""
    if cell is None:
        return ""
    s = cell.summary
    if s["makespan_mean"] is None:
        return "-"
    if s["makespan_min"] == s["makespan_max"]:
        return f"{s['makespan_mean']:.1f}"
    return f"{s['makespan_mean']:.1f} ({s['makespan_min']}-{s['makespan_max']})"


def _success(cell: Cell | None) -> str:
    if cell is None:
        return ""
    done = sum(r["success"] for r in cell.results)
    return f"{done}/{len(cell.results)}"


def main_rows(res: Results) -> list[list[str]]:
    """Makespan and success of every (scenario, cranes), beside the optimum where it applies."""
    rows = []
    for name in res.setup.scenarios:
        for n in res.setup.cranes:
            g = res.cells.get((name, n, "greedy"))
            p = res.cells.get((name, n, "prioritized"))
            r = res.cells.get((name, n, "random"))
            o = res.optimal.get(name) if n == 1 else None
            delta = ""
            if g and p and g.summary["makespan_mean"] and p.summary["makespan_mean"]:
                gm, pm = g.summary["makespan_mean"], p.summary["makespan_mean"]
                delta = f"{100 * (pm - gm) / gm:+.0f} %"
            rows.append(
                [
                    name,
                    str(n),
                    _make(g),
                    _success(g),
                    num(g.summary["blocked_moves_mean"]) if g else "",
                    _make(p),
                    _success(p),
                    num(p.summary["blocked_moves_mean"]) if p else "",
                    delta,
                    _make(r),
                    _success(r),
                    f"{o.steps:.1f}" if o else "",
                    f"{o.comparable:.1f}" if o else "",
                ]
            )
    return rows


def speedup_rows(res: Results) -> list[list[str]]:
    """Makespan with n cranes relative to 1 crane (large scenarios)."""
    rows = []
    if 1 not in res.setup.cranes:
        return rows
    for name in res.setup.scenarios:
        if name not in LARGE:
            continue
        for policy in PLANNERS:
            base = res.cells.get((name, 1, policy))
            if base is None or base.summary["makespan_mean"] is None:
                continue
            b = base.summary["makespan_mean"]
            row = [name, policy]
            for n in res.setup.cranes:
                c = res.cells.get((name, n, policy))
                m = c.summary["makespan_mean"] if c else None
                row.append("-" if m is None else f"{m:.1f} (x{b / m:.2f})")
            u = [res.cells.get((name, n, policy)) for n in res.setup.cranes]
            row.append(" / ".join(f"{c.summary['utilisation_mean']:.0%}" if c else "-" for c in u))
            rows.append(row)
    return rows


def speedup_head(res: Results) -> list[str]:
    """The header of ``speedup_rows``: a column per crane count, then the utilisation."""
    counts = [f"{n} crane{'s' if n > 1 else ''}" for n in res.setup.cranes]
    return ["scenario", "planner", *counts, "utilisation"]


def timing_rows(res: Results) -> list[list[str]]:
    """Planning time per decision of the planners (large scenarios)."""
    rows = []
    for name in res.setup.scenarios:
        if name not in LARGE:
            continue
        for n in res.setup.cranes:
            for policy in PLANNERS:
                c = res.cells.get((name, n, policy))
                if c is None:
                    continue
                s = c.summary
                rows.append(
                    [
                        name,
                        str(n),
                        policy,
                        f"{s['plan_ms_per_step']:.2f}",
                        f"{s['plan_ms_per_crane']:.2f}",
                        f"{s['plan_ms_max']:.1f}",
                    ]
                )
    return rows


def _values(values: list) -> str:
    """Mean of the values, (min-max) when they differ."""
    if not values:
        return "-"
    mean = sum(values) / len(values)
    lo, hi = min(values), max(values)
    return f"{mean:.1f}" if lo == hi else f"{mean:.1f} ({lo}-{hi})"


def _gap(res: Results, name: str, n: int, policy: str) -> str:
    gaps = res.gaps(name, n, policy)
    return "-" if not gaps else f"{100 * sum(gaps) / len(gaps):.1f} %"


def bound_rows(res: Results) -> list[list[str]]:
    """The lower bound of every setting and each planner's mean gap to it."""
    rows = []
    for name in res.setup.scenarios:
        for n in res.setup.cranes:
            b = res.bounds.get((name, n))
            if b is None:
                continue
            row = [name, str(n), _values(b.values), f"{b.proven}/{len(b.values)}"]
            for policy in PLANNERS:
                row += [_make(res.cells.get((name, n, policy))), _gap(res, name, n, policy)]
            rows.append(row)
    return rows


def task_rows(res: Results) -> list[list[str]]:
    """The prioritized rule in task mode beside motion mode (large scenarios)."""
    rows = []
    for name in res.setup.scenarios:
        for n in res.setup.cranes:
            t = res.task.get((name, n))
            p = res.cells.get((name, n, "prioritized"))
            if t is None or p is None:
                continue
            done = [m for m in t.makespans if m is not None]
            steps = sum(r["steps"] for r in p.results)
            rows.append(
                [
                    name,
                    str(n),
                    _values(done),
                    "yes" if t.same_as_motion else "no",
                    f"{t.rounds:.1f}",
                    f"{t.ms_per_round:.2f}",
                    f"{steps / len(p.results):.1f}",
                    f"{1000.0 * p.seconds / steps:.2f}",
                ]
            )
    return rows
