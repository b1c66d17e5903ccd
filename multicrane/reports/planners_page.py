"""The planner comparison as a report: observations, the markdown page, the plain-text report.

``multicrane compare-planners`` prints or writes it (``docs/planners.md``).
"""

from __future__ import annotations

import datetime
import statistics

from multicrane.reports.planners import LARGE, PLANNERS, STAT_KEYS, Results
from multicrane.reports.planners_tables import (
    BOUND_HEAD,
    HEAD,
    TASK_HEAD,
    TIMING_HEAD,
    bound_rows,
    cranes,
    main_rows,
    markdown,
    speedup_rows,
    task_rows,
    timing_rows,
)
from multicrane.reports.planners_tables import text as text_table
from multicrane.reports.provenance import machine


def _mean(cells: dict, name: str, n: int, policy: str) -> float | None:
    c = cells.get((name, n, policy))
    return c.summary["makespan_mean"] if c else None


def observations(res: Results) -> list[str]:
    """Statements read off the numbers (only about what was run)."""
    cells, optimal, args = res.cells, res.optimal, res.setup
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
        missed = [f"{s} with {cranes(n)}" for s, n in run if (s, n) not in full]
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
                f"{s} with {cranes(n)} {_mean(cells, s, n, 'greedy'):.1f} -> "
                f"{_mean(cells, s, n, 'prioritized'):.1f}"
                f" ({100 * diff[(s, n)] / _mean(cells, s, n, 'greedy'):+.0f} %)"
                for s, n in gains
            )
            text += "."
        if worse:
            text += " Longer: " + "; ".join(
                f"{s} with {cranes(n)} ({diff[(s, n)]:+.1f} steps)" for s, n in worse
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
            text += ": " + ", ".join(f"{s} with {cranes(n)}" for s, n in ok)
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
    notes += gap_notes(res)
    return notes


def gap_notes(res: Results) -> list[str]:
    """What the lower bound says of each planner: mean gap, by crane count, and the largest."""
    notes = []
    keys = list(res.bounds)
    for policy in PLANNERS:
        gaps = {k: res.gaps(*k, policy) for k in keys}
        gaps = {k: statistics.fmean(g) for k, g in gaps.items() if g}
        if not gaps:
            continue
        by_n = []
        for n in res.setup.cranes:
            g = [v for (_, m), v in gaps.items() if m == n]
            if g:
                by_n.append(f"{statistics.fmean(g):.1%} with {cranes(n)}")
        (name, n), worst = max(gaps.items(), key=lambda kv: kv[1])
        mean = statistics.fmean(gaps.values())
        notes.append(
            f"**{policy.capitalize()} vs. the lower bound.** Mean gap {mean:.1%} "
            f"over {len(gaps)} settings ({', '.join(by_n)}); largest {worst:.1%} ({name} with "
            f"{cranes(n)}). The bound relaxes collisions between cranes, so with more cranes a "
            "growing part of the gap is the bound's, not the planner's."
        )
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


def markdown_page(res: Results, command: str) -> str:
    """The whole page: how it was made, the policies, definitions, tables, observations."""
    args, wall = res.setup, res.wall
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
        f"- Command: `{command}`.",
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
        "- **optimal (auto) steps**: `multicrane.bounds.paper_optimum.plan(config, seed)`, the "
        "exact optimum "
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
    out += markdown(HEAD, main_rows(res), left=1)
    speed = speedup_rows(res)
    if speed:
        out += [
            "",
            "## Scaling with cranes (large scenarios)",
            "",
            "Mean makespan with n cranes (speed-up over one crane); utilisation per crane count.",
            "",
        ]
        head = ["scenario", "planner", *(f"{n} crane{'s' if n > 1 else ''}" for n in args.cranes)]
        out += markdown([*head, "utilisation"], speed, left=2)
    bounds = bound_rows(res)
    if bounds:
        out += [
            "",
            "## Lower bound and gaps",
            "",
            "The makespan lower bound of each episode (`multicrane bound`, CP-SAT; "
            "[bound.md](bound.md) states the model and why it is a bound), mean over the "
            "planners' seeds; *proven*: seeds whose relaxation the solver solved to optimality; "
            "*gap*: (makespan - bound) / bound per completed episode, its own bound, mean over "
            "episodes. Part of every gap is the bound's (it ignores collisions between cranes).",
            "",
        ]
        out += markdown(BOUND_HEAD, bounds, left=2)
    tasks = task_rows(res)
    if tasks:
        out += [
            "",
            "## Task mode (large scenarios)",
            "",
            "The prioritized rule as a task-level policy (`decisions=\"task\"`, "
            "[task-mode.md](task-mode.md)) on the same seeds: makespan, whether it equals the "
            "motion-mode planner's on every seed, decision rounds (`env.step` calls) per "
            "episode and wall time per round (the policy, the carrier's planning and the "
            "simulated steps together), beside motion mode's joint steps per episode and wall "
            "time per joint step (policy and environment).",
            "",
        ]
        out += markdown(TASK_HEAD, tasks, left=2)
    timing = timing_rows(res)
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
        out += markdown(TIMING_HEAD, timing, left=3)
    out += ["", "## Observations", ""]
    for note in observations(res):
        out += [f"- {note}", ""]
    out += ["## Limitations of the prioritized planner", ""]
    for note in LIMITATIONS:
        out += [f"- {note}", ""]
    return "\n".join(out)


def text_report(res: Results) -> str:
    """The tables and observations as plain text."""
    parts = [text_table(HEAD, main_rows(res))]
    for head, rows in ((BOUND_HEAD, bound_rows(res)), (TASK_HEAD, task_rows(res))):
        if rows:
            parts.append(text_table(head, rows))
    timing = timing_rows(res)
    if timing:
        parts.append(text_table(TIMING_HEAD, timing))
    parts += [f"- {n}" for n in observations(res)]
    parts.append(f"Total wall time {res.wall:.1f} s.")
    return "\n\n".join(parts) + "\n"


