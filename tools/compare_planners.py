"""Classical multi-crane planners on every shipped scenario with 1-4 cranes: the baselines RL
must beat.

    python tools/compare_planners.py                                # text tables
    python tools/compare_planners.py --markdown --output docs/planners.md
    python tools/compare_planners.py --scenarios hall-4c frame2-3c --cranes 1 4 --seeds 3

For each scenario (default: all, ``multicrane.scenario_names()``) and each crane count
(default 1 2 3 4) it plays, in ``MultiCraneEnv``'s default (claiming) mode, the episodes that
``reset(seed=first + i)`` starts:

- greedy: ``policies.greedy.GreedyPolicy`` (nearest ready component, shortest path treating
  the others as fixed, wait when blocked, random shake after 3 blocked steps), ``--seeds``
  episodes;
- prioritized: ``policies.prioritized.PrioritizedPlanner`` (space-time A* with a reservation
  table, greedy assignment in list order), ``--seeds`` episodes;
- random: ``policies.random_policy.RandomPolicy`` (uniform over the legal actions, seeded per
  episode with (seed, 1)), ``--random-seeds`` episodes (it mostly runs to the step limit);
- optimal (paper configurations e?s? with 1 crane only): ``policies.optimal.plan``, the exact
  best return of the paper's automatic mode for the same seeds (same layouts). Its step
  count is comparable but not identical in definition: in automatic mode the first move
  lifts the component and arrival assembles it, while in the claiming mode a claim step
  lifts it and an assemble step ends it, 2 more steps per component; Env1's pre-built column
  costs the automatic mode one pass-over step. ``opt+2/comp`` converts: optimal steps - pass-
  overs + 2 x components assembled.

Metrics (``policies.metrics``): makespan (joint steps to complete; mean over completed
episodes), success rate, blocked moves per episode, crane utilisation, and the planning time
per decision: wall time inside the policy call per joint step (one call decides all cranes),
and per crane decision (divided by the number of cranes). Progress goes to stderr.
"""

from __future__ import annotations

import argparse
import datetime
import os
import re
import statistics
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import multicrane  # noqa: E402
from multicrane.rollout import run_episode, summarise  # noqa: E402
from multicrane.types import EventType  # noqa: E402
from policies import make  # noqa: E402
from tools.report import command_line, machine  # noqa: E402

PLANNERS = ("greedy", "prioritized")
POLICIES = ("greedy", "prioritized", "random")
PAPER = re.compile(r"^e[1-4]s[1-4]$")
LARGE = ("frame2-3c", "hall-4c")
STAT_KEYS = ("searches", "failed", "expansions", "claims", "replans", "repairs", "fallbacks")


@dataclass
class Cell:
    """One policy on one (scenario, crane count): per-episode results and their summary."""

    results: list[dict]
    summary: dict
    seconds: float
    stats: dict = field(default_factory=dict)  # planner counters (prioritized only)


@dataclass
class Optimal:
    steps: float
    comparable: float  # steps - pass-overs + 2 per component assembled
    success: float
    seconds: float


def run_cell(scenario: str, n: int, policy: str, seeds: range) -> Cell:
    env = multicrane.parallel_env(scenario, n_cranes=n)
    start = time.perf_counter()
    results = []
    stats = dict.fromkeys(STAT_KEYS, 0)
    for seed in seeds:
        p = make(policy, env, seed)
        results.append(run_episode(env, p, seed=seed))
        for k, v in getattr(p, "stats", {}).items():
            stats[k] = stats.get(k, 0) + v
    return Cell(results, summarise(results), time.perf_counter() - start, stats)


def run_optimal(scenario: str, seeds: range) -> Optimal:
    from multicrane.optimal import plan

    start = time.perf_counter()
    steps, comparable, success = [], [], []
    for seed in seeds:
        p = plan(scenario.upper(), seed)
        env = multicrane.PaperAssemblyEnv(scenario.upper())
        env.reset(seed=seed)
        passes = 0
        for a in p.actions:
            info = env.step(a)[4]
            passes += sum(1 for e in info["events"] if e.type == EventType.PASS_OVER)
        steps.append(p.steps)
        comparable.append(p.steps - passes + 2 * env.sim.k)
        success.append(p.success)
    return Optimal(
        statistics.fmean(steps),
        statistics.fmean(comparable),
        sum(success) / len(success),
        time.perf_counter() - start,
    )


def run_all(args: argparse.Namespace) -> tuple[dict, dict]:
    cells: dict[tuple[str, int, str], Cell] = {}
    optimal: dict[str, Optimal] = {}
    seeds = range(args.seed, args.seed + args.seeds)
    random_seeds = range(args.seed, args.seed + args.random_seeds)
    for name in args.scenarios:
        for n in args.cranes:
            for policy in args.policies:
                chosen = random_seeds if policy == "random" else seeds
                if not len(chosen):
                    continue
                cell = run_cell(name, n, policy, chosen)
                cells[name, n, policy] = cell
                s = cell.summary
                print(
                    f"{name:<10} {n} {policy:<12} success {s['success_rate']:>4.0%} "
                    f"makespan {_num(s['makespan_mean'])} ({cell.seconds:.1f} s)",
                    file=sys.stderr,
                    flush=True,
                )
        if args.optimal and PAPER.match(name) and 1 in args.cranes:
            optimal[name] = run_optimal(name, seeds)
    return cells, optimal


# -- formatting -----------------------------------------------------------------------------------


def _num(x: float | None, digits: int = 1) -> str:
    return "-" if x is None else f"{x:.{digits}f}"


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


def _rows(cells: dict, optimal: dict, args: argparse.Namespace) -> list[list[str]]:
    rows = []
    for name in args.scenarios:
        for n in args.cranes:
            g = cells.get((name, n, "greedy"))
            p = cells.get((name, n, "prioritized"))
            r = cells.get((name, n, "random"))
            o = optimal.get(name) if n == 1 else None
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
                    _num(g.summary["blocked_moves_mean"]) if g else "",
                    _make(p),
                    _success(p),
                    _num(p.summary["blocked_moves_mean"]) if p else "",
                    delta,
                    _make(r),
                    _success(r),
                    f"{o.steps:.1f}" if o else "",
                    f"{o.comparable:.1f}" if o else "",
                ]
            )
    return rows


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


def _speedups(cells: dict, args: argparse.Namespace) -> list[list[str]]:
    """Makespan with n cranes relative to 1 crane (large scenarios)."""
    rows = []
    if 1 not in args.cranes:
        return rows
    for name in args.scenarios:
        if name not in LARGE:
            continue
        for policy in PLANNERS:
            base = cells.get((name, 1, policy))
            if base is None or base.summary["makespan_mean"] is None:
                continue
            b = base.summary["makespan_mean"]
            row = [name, policy]
            for n in args.cranes:
                c = cells.get((name, n, policy))
                m = c.summary["makespan_mean"] if c else None
                row.append("-" if m is None else f"{m:.1f} (x{b / m:.2f})")
            u = [cells.get((name, n, policy)) for n in args.cranes]
            row.append(" / ".join(f"{c.summary['utilisation_mean']:.0%}" if c else "-" for c in u))
            rows.append(row)
    return rows


def _timing_rows(cells: dict, args: argparse.Namespace) -> list[list[str]]:
    rows = []
    for name in args.scenarios:
        if name not in LARGE:
            continue
        for n in args.cranes:
            for policy in PLANNERS:
                c = cells.get((name, n, policy))
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


TIMING_HEAD = [
    "scenario",
    "cranes",
    "planner",
    "ms per joint decision",
    "ms per crane decision",
    "slowest call (ms)",
]


def _text(head: list[str], rows: list[list[str]]) -> str:
    widths = [max(len(h), *(len(r[i]) for r in rows)) for i, h in enumerate(head)] if rows else []
    lines = ["  ".join(h.rjust(w) for h, w in zip(head, widths, strict=True))]
    lines += ["  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)) for r in rows]
    return "\n".join(lines)


def _md(head: list[str], rows: list[list[str]], left: int = 1) -> list[str]:
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * left + "---:|" * (len(head) - left)]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return out


def _cranes(n: int) -> str:
    return f"{n} crane{'s' if n != 1 else ''}"


def _mean(cells: dict, name: str, n: int, policy: str) -> float | None:
    c = cells.get((name, n, policy))
    return c.summary["makespan_mean"] if c else None


def observations(cells: dict, optimal: dict, args: argparse.Namespace) -> list[str]:
    """Statements read off the numbers (only about what was run)."""
    notes = []
    keys = [(s, n) for s in args.scenarios for n in args.cranes]
    for policy in PLANNERS:
        run = [k for k in keys if (*k, policy) in cells]
        if not run:
            continue
        full = [k for k in run if cells[(*k, policy)].summary["success_rate"] == 1.0]
        blocked = sum(r["blocked_moves"] for k in run for r in cells[(*k, policy)].results)
        failed = sum(r["failed_actions"] for k in run for r in cells[(*k, policy)].results)
        episodes = sum(len(cells[(*k, policy)].results) for k in run)
        text = (
            f"**{policy.capitalize()}** completes every episode in {len(full)} of {len(run)} "
            f"(scenario, cranes) settings; {blocked} blocked moves and {failed} other failed "
            f"actions in {episodes} episodes."
        )
        missed = [f"{s} with {_cranes(n)}" for s, n in run if (s, n) not in full]
        if missed:
            text += " Not always completed: " + ", ".join(missed) + "."
        notes.append(text)

    both = [
        k
        for k in keys
        if _mean(cells, *k, "greedy") is not None and _mean(cells, *k, "prioritized") is not None
    ]
    if both:
        diff = {k: _mean(cells, *k, "prioritized") - _mean(cells, *k, "greedy") for k in both}
        better = [k for k in both if diff[k] < -0.05]
        worse = [k for k in both if diff[k] > 0.05]
        same = len(both) - len(better) - len(worse)
        gains = sorted(better, key=lambda k: diff[k] / _mean(cells, *k, "greedy"))[:4]
        text = (
            f"**Prioritized vs. greedy (mean makespan).** Shorter in {len(better)}, equal in "
            f"{same} and longer in {len(worse)} of {len(both)} settings."
        )
        if gains:
            text += " Largest gains: " + "; ".join(
                f"{s} with {_cranes(n)} {_mean(cells, s, n, 'greedy'):.1f} -> "
                f"{_mean(cells, s, n, 'prioritized'):.1f}"
                f" ({100 * diff[(s, n)] / _mean(cells, s, n, 'greedy'):+.0f} %)"
                for s, n in gains
            )
            text += "."
        if worse:
            text += " Longer: " + "; ".join(
                f"{s} with {_cranes(n)} ({diff[(s, n)]:+.1f} steps)" for s, n in worse
            )
            text += "."
        one = [k for k in both if k[1] == 1]
        multi = [k for k in both if k[1] > 1]
        if one and multi:
            text += (
                f" With one crane there is nothing to coordinate and the two differ by "
                f"{statistics.fmean(diff[k] for k in one):+.1f} steps on average; with 2-4 "
                f"cranes by {statistics.fmean(diff[k] for k in multi):+.1f}: the greedy "
                "policy's waiting and random shaking when cranes block each other is what "
                "the reservations remove."
            )
        notes.append(text)

    for policy in PLANNERS:
        parts = []
        for name in args.scenarios:
            if name not in LARGE:
                continue
            m1 = _mean(cells, name, 1, policy)
            if m1 is None:
                continue
            parts.append(
                f"{name} "
                + ", ".join(
                    f"{n} cranes x{m1 / m:.2f}"
                    for n in args.cranes
                    if n > 1 and (m := _mean(cells, name, n, policy))
                )
            )
        if parts:
            notes.append(
                f"**Speed-up over one crane, {policy}** (makespan with 1 crane / with n): "
                + "; ".join(parts)
                + "."
            )

    flat = [
        s
        for s in args.scenarios
        if all(
            _mean(cells, s, n, "prioritized") == _mean(cells, s, 1, "prioritized")
            for n in args.cranes
        )
        and (s, 1, "prioritized") in cells
        and len(args.cranes) > 1
    ]
    if flat:
        text = (
            f"**Precedence-bound scenarios.** In {', '.join(flat)} more cranes do not shorten "
            "the prioritized planner's makespan"
        )
        if all(s.startswith("e1") for s in flat):
            text += (
                ": Env1 has two components to move, a column and the beam that rests on it, "
                "and the beam can only be claimed once the column is assembled, so there is "
                "never more than one component to carry"
            )
        notes.append(text + ".")

    if optimal:
        gaps = []
        for name, o in optimal.items():
            p = _mean(cells, name, 1, "prioritized")
            if p is not None:
                gaps.append((name, p - o.comparable))
        if gaps:
            worst = max(gaps, key=lambda g: g[1])
            best = min(gaps, key=lambda g: g[1])
            notes.append(
                "**One crane vs. the single-agent optimum** (claiming-mode makespan minus "
                "optimal automatic-mode steps converted with +2 per component, a pass-over "
                f"removed): {statistics.fmean(g for _, g in gaps):+.1f} steps on average, from "
                f"{best[1]:+.1f} ({best[0]}) to {worst[1]:+.1f} ({worst[0]}). The optimum "
                "follows the list order's pointer and chooses the best targets; the "
                "prioritized planner picks components in list order too, but each target "
                "greedily; negative values are possible because the claiming mode may take "
                "any claimable component, not only the pointer's."
            )

    rand = [k for k in keys if (*k, "random") in cells]
    if rand:
        ok = [k for k in rand if cells[(*k, "random")].summary["success_rate"] > 0]
        text = (
            f"**Random** (uniform over legal actions) completes at least one episode in "
            f"{len(ok)} of {len(rand)} settings"
        )
        if ok:
            text += ": " + ", ".join(f"{s} with {_cranes(n)}" for s, n in ok)
        notes.append(text + ".")

    timing = [
        (name, n)
        for name in args.scenarios
        for n in args.cranes
        if (name, n, "prioritized") in cells
    ]
    if timing:
        worst = max(timing, key=lambda k: cells[(*k, "prioritized")].summary["plan_ms_per_step"])
        s = cells[(*worst, "prioritized")].summary
        slowest = max(cells[(*k, "prioritized")].summary["plan_ms_max"] for k in timing)
        text = (
            f"**Planning time.** The prioritized planner's highest mean per joint decision is "
            f"{s['plan_ms_per_step']:.2f} ms ({worst[0]} with {worst[1]} cranes), its slowest "
            f"single call {slowest:.1f} ms; most decisions only read the next step of each "
            "plan, the searches happen at claims (one A* per claimed component) and replans."
        )
        if ("hall-4c", 4, "prioritized") in cells:
            h = cells[("hall-4c", 4, "prioritized")].summary
            text += (
                f" On hall-4c with 4 cranes: {h['plan_ms_per_step']:.2f} ms per joint decision, "
                f"{h['plan_ms_per_crane']:.2f} ms per crane decision, slowest call "
                f"{h['plan_ms_max']:.1f} ms (requirement: well under 50 ms)."
            )
        stats = {
            k: sum(cells[(*t, "prioritized")].stats.get(k, 0) for t in timing) for k in STAT_KEYS
        }
        text += (
            f" Over all its episodes: {stats['searches']} searches ({stats['failed']} failed, "
            f"{stats['expansions']} states expanded), {stats['replans']} full replans, "
            f"{stats['repairs']} path repairs, {stats['fallbacks']} mask fallbacks."
        )
        notes.append(text)
    return notes


LIMITATIONS = (
    "**Incomplete, as prioritized planning is.** Earlier plans never yield: a component is "
    "claimed only when a whole path exists around the paths already planned, so a crane may "
    "wait although a joint plan would let it go. A component in transit left without a plan "
    "(possible only after a full replan; see the counters above) keeps its cells and stops "
    "new claims until it finds one; two such components could wait for each other for ever.",
    "**Greedy assignment.** Components are taken in list order, each to the nearest free "
    "ready target by Manhattan distance; neither the order nor the targets are optimised for "
    "makespan (see the one-crane gap to the optimum above), and crane counts beyond the "
    "number of ready components simply idle.",
    "**Conservative target poses.** A path never crosses the pose of another target the "
    "component could fill that is ready or may become ready, which can lengthen paths.",
    "**Plans assume the rules are deterministic.** They are; a site that differed from the "
    "plan (an arrival the plan did not foresee) would trigger a full replan of every "
    "component in transit.",
)


def markdown_page(
    cells: dict, optimal: dict, args: argparse.Namespace, wall: float, argv: list[str] | None
) -> str:
    seeds = f"seeds {args.seed}..{args.seed + args.seeds - 1}"
    rseeds = (
        f"seeds {args.seed}..{args.seed + args.random_seeds - 1}" if args.random_seeds else "none"
    )
    out = [
        "# Classical multi-crane planners: the baselines RL must beat",
        "",
        "What a greedy planner, a prioritized planner with space-time reservations and uniform "
        "random actions achieve on every shipped scenario with 1 to 4 cranes, in "
        "`MultiCraneEnv`'s default (claiming) mode, beside the single-agent optimum where it "
        "applies. A learned multi-crane policy should be compared with the *prioritized* "
        "column: it is what a good classical planner achieves on the same scenarios and seeds.",
        "",
        f"- Command: `{command_line(__file__, argv)}` (from the repository root).",
        f"- Date: {datetime.date.today().isoformat()}.",
        f"- Machine: {machine()}.",
        f"- Episodes: greedy and prioritized {args.seeds} per setting ({seeds}, passed to "
        f"`reset(seed=...)`); random {args.random_seeds} per setting ({rseeds}; it mostly runs "
        "to the step limit); optimal on the planners' seeds.",
        f"- Total wall time {wall:.0f} s.",
        "",
        "## Policies",
        "",
        "- **greedy**: `policies.greedy.GreedyPolicy`. Each idle crane claims the ready "
        "component nearest to a target; the component follows a shortest path that treats every "
        "other component as a fixed obstacle; a blocked crane waits and replans, and after 3 "
        "blocked steps makes a random legal move.",
        "- **prioritized**: `policies.prioritized.PrioritizedPlanner`. Cooperative A* in space "
        "and time for each rigid component against a reservation table of the paths already "
        "planned (a component never enters a cell another occupies in the same or the previous "
        "step, so plans hold whatever order the cranes act in), goals held for ever from the "
        "arrival, pick-up poses checked at the claim step; ready components claimed in the "
        "scenario's list order, each to the nearest free ready target, only when a full "
        "collision-free path exists; replanning when the site differs from the plan.",
        "- **random**: `policies.random_policy.RandomPolicy`, uniform over the legal actions "
        "(seeded per episode with (seed, 1)).",
        "- **optimal (auto) steps**: `policies.optimal.plan(config, seed)`, the exact optimum "
        "of the paper's single-agent *automatic* mode for the same layouts (e?s? with one crane "
        "only). It is a different process: there the first move lifts the component and the "
        "arrival assembles it; here a claim step lifts it and an assemble step finishes it. "
        "The step counts are comparable but not identical in definition; *opt+2/comp* converts "
        "the optimum to the claiming mode's count (steps - pass-over steps + 2 x components "
        "assembled). The optimum maximises the paper's return, which for a fixed order means "
        "shortest paths; it is not a makespan bound for other component orders.",
        "",
        "## Definitions",
        "",
        "- *makespan*: joint steps (`env.step` calls) to complete the building, mean over the "
        "completed episodes, (min-max) when they differ; `-` when none completed.",
        "- *ok*: completed episodes / episodes (within the scenario's step limit).",
        "- *blocked*: `BLOCKED` events per episode (moves refused because the cell was taken, "
        "e.g. by a component another crane moved earlier in the same step).",
        "- *prio vs greedy*: relative difference of the mean makespans (negative: prioritized "
        "finishes sooner).",
        "- *utilisation*: crane-steps in which a crane held a component (at the start or the "
        "end of the step: claiming, carrying, waiting loaded, assembling) over cranes x steps; "
        "the rest is idle time.",
        "- *planning time per decision*: wall time inside the policy call per joint step (one "
        "call decides the actions of all cranes), and per crane decision (the same divided by "
        "the number of cranes); slowest call: the longest single call.",
        "",
        "## Makespan and success",
        "",
    ]
    out += _md(HEAD, _rows(cells, optimal, args), left=1)
    speed = _speedups(cells, args)
    if speed:
        out += [
            "",
            "## Scaling with cranes (large scenarios)",
            "",
            "Mean makespan with n cranes (speed-up over one crane); utilisation per crane count.",
            "",
        ]
        head = ["scenario", "planner", *(f"{n} crane{'s' if n > 1 else ''}" for n in args.cranes)]
        out += _md([*head, "utilisation"], speed, left=2)
    timing = _timing_rows(cells, args)
    if timing:
        out += [
            "",
            "## Planning time per decision (large scenarios)",
            "",
            "Pooled over the episodes of each setting (total time in the policy over total "
            "joint steps); a shared 2-core machine, so figures vary by some tens of percent "
            "between runs.",
            "",
        ]
        out += _md(TIMING_HEAD, timing, left=3)
    out += ["", "## Observations", ""]
    for note in observations(cells, optimal, args):
        out += [f"- {note}", ""]
    out += ["## Limitations of the prioritized planner", ""]
    for note in LIMITATIONS:
        out += [f"- {note}", ""]
    return "\n".join(out)


def text_report(cells: dict, optimal: dict, args: argparse.Namespace, wall: float) -> str:
    parts = [_text(HEAD, _rows(cells, optimal, args))]
    timing = _timing_rows(cells, args)
    if timing:
        parts.append(_text(TIMING_HEAD, timing))
    parts += [f"- {n}" for n in observations(cells, optimal, args)]
    parts.append(f"Total wall time {wall:.1f} s.")
    return "\n\n".join(parts) + "\n"


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--scenarios", nargs="+", default=multicrane.scenario_names())
    p.add_argument("--cranes", nargs="+", type=int, default=[1, 2, 3, 4])
    p.add_argument("--policies", nargs="+", default=list(POLICIES), choices=list(POLICIES))
    p.add_argument("--seeds", type=int, default=5, help="episodes per setting (planners)")
    p.add_argument("--random-seeds", type=int, default=2, help="episodes per setting (random)")
    p.add_argument("--seed", type=int, default=0, help="first episode seed")
    p.add_argument("--no-optimal", dest="optimal", action="store_false")
    p.add_argument("--markdown", action="store_true", help="print a whole markdown page")
    p.add_argument("--output", type=Path, help="write the report here instead of stdout")
    args = p.parse_args(argv)
    unknown = [s for s in args.scenarios if s not in multicrane.scenario_names()]
    if unknown:
        p.error(f"unknown scenario(s): {', '.join(unknown)}")
    if args.seeds < 1:
        p.error("--seeds must be at least 1")
    return args


def main(argv: list[str] | None = None) -> int:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    args = parse_args(argv)
    start = time.perf_counter()
    cells, optimal = run_all(args)
    wall = time.perf_counter() - start
    if args.markdown:
        report = markdown_page(cells, optimal, args, wall, argv)
    else:
        report = text_report(cells, optimal, args, wall)
    if args.output:
        args.output.parent.mkdir(parents=True, exist_ok=True)
        args.output.write_text(report + ("" if report.endswith("\n") else "\n"))
        print(f"wrote {args.output}", file=sys.stderr)
    else:
        sys.stdout.write(report)
    return 0


if __name__ == "__main__":
    sys.exit(main())
