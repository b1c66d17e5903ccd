"""The observations of the planner comparison: statements read off its numbers.

Each note is about what was run only; a note whose numbers are missing is left out.
``observations`` lists them in the page's order.
"""

from __future__ import annotations

import statistics

from multicrane.reports.planners import LARGE, PLANNERS, STAT_KEYS, Results
from multicrane.reports.planners_tables import cranes

Setting = tuple[str, int]  # (scenario, crane count)


def observations(res: Results) -> list[str]:
    """Statements read off the numbers (only about what was run)."""
    notes = completion_notes(res)
    notes += [versus_greedy_note(res)]
    notes += speedup_notes(res)
    notes += [precedence_note(res), optimum_note(res), random_note(res), timing_note(res)]
    notes += gap_notes(res)
    return [note for note in notes if note is not None]


def _mean(res: Results, name: str, n: int, policy: str) -> float | None:
    c = res.cells.get((name, n, policy))
    return c.summary["makespan_mean"] if c else None


def _settings(res: Results) -> list[Setting]:
    return [(s, n) for s in res.setup.scenarios for n in res.setup.cranes]


def _run(res: Results, policy: str) -> list[Setting]:
    """The settings ``policy`` was run on."""
    return [k for k in _settings(res) if (*k, policy) in res.cells]


def completion_notes(res: Results) -> list[str]:
    """Per planner: the settings where it completes every episode, blocked and failed moves."""
    cells, notes = res.cells, []
    for policy in PLANNERS:
        run = _run(res, policy)
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
    return notes


def versus_greedy_note(res: Results) -> str | None:
    """Prioritized against greedy: where it is shorter or longer, its largest gains."""
    both = [
        k
        for k in _settings(res)
        if _mean(res, *k, "greedy") is not None and _mean(res, *k, "prioritized") is not None
    ]
    if not both:
        return None
    diff = {k: _mean(res, *k, "prioritized") - _mean(res, *k, "greedy") for k in both}
    better = [k for k in both if diff[k] < -0.05]
    worse = [k for k in both if diff[k] > 0.05]
    same = len(both) - len(better) - len(worse)
    gains = sorted(better, key=lambda k: diff[k] / _mean(res, *k, "greedy"))[:4]
    text = (
        f"**Prioritized vs. greedy (mean makespan).** Shorter in {len(better)}, equal in "
        f"{same} and longer in {len(worse)} of {len(both)} settings."
    )
    if gains:
        text += " Largest gains: " + "; ".join(
            f"{s} with {cranes(n)} {_mean(res, s, n, 'greedy'):.1f} -> "
            f"{_mean(res, s, n, 'prioritized'):.1f}"
            f" ({100 * diff[(s, n)] / _mean(res, s, n, 'greedy'):+.0f} %)"
            for s, n in gains
        )
        text += "."
    if worse:
        text += " Longer: " + "; ".join(
            f"{s} with {cranes(n)} ({diff[(s, n)]:+.1f} steps)" for s, n in worse
        )
        text += "."
    return text + _one_and_more_cranes(diff)


def _one_and_more_cranes(diff: dict[Setting, float]) -> str:
    """The mean difference with one crane beside that with several, when both were run."""
    one = [k for k in diff if k[1] == 1]
    multi = [k for k in diff if k[1] > 1]
    if not (one and multi):
        return ""
    return (
        f" With one crane there is nothing to coordinate and the two differ by "
        f"{statistics.fmean(diff[k] for k in one):+.1f} steps on average; with 2-4 "
        f"cranes by {statistics.fmean(diff[k] for k in multi):+.1f}: the greedy "
        "policy's waiting and random shaking when cranes block each other is what "
        "the reservations remove."
    )


def speedup_notes(res: Results) -> list[str]:
    """Per planner: the makespan with one crane over that with n, on the large scenarios."""
    notes = []
    for policy in PLANNERS:
        parts = []
        for name in res.setup.scenarios:
            if name not in LARGE:
                continue
            m1 = _mean(res, name, 1, policy)
            if m1 is None:
                continue
            parts.append(
                f"{name} "
                + ", ".join(
                    f"{n} cranes x{m1 / m:.2f}"
                    for n in res.setup.cranes
                    if n > 1 and (m := _mean(res, name, n, policy))
                )
            )
        if parts:
            notes.append(
                f"**Speed-up over one crane, {policy}** (makespan with 1 crane / with n): "
                + "; ".join(parts)
                + "."
            )
    return notes


def precedence_note(res: Results) -> str | None:
    """The scenarios where more cranes do not shorten the prioritized planner's makespan."""
    args = res.setup
    flat = [
        s
        for s in args.scenarios
        if all(
            _mean(res, s, n, "prioritized") == _mean(res, s, 1, "prioritized")
            for n in args.cranes
        )
        and (s, 1, "prioritized") in res.cells
        and len(args.cranes) > 1
    ]
    if not flat:
        return None
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
    return text + "."


def optimum_note(res: Results) -> str | None:
    """One crane of the prioritized planner against the single-agent optimum."""
    gaps = []
    for name, o in res.optimal.items():
        p = _mean(res, name, 1, "prioritized")
        if p is not None:
            gaps.append((name, p - o.comparable))
    if not gaps:
        return None
    worst = max(gaps, key=lambda g: g[1])
    best = min(gaps, key=lambda g: g[1])
    return (
        "**One crane vs. the single-agent optimum** (claiming-mode makespan minus "
        "optimal automatic-mode steps converted with +2 per component, a pass-over "
        f"removed): {statistics.fmean(g for _, g in gaps):+.1f} steps on average, from "
        f"{best[1]:+.1f} ({best[0]}) to {worst[1]:+.1f} ({worst[0]}). The optimum "
        "follows the list order's pointer and chooses the best targets; the "
        "prioritized planner picks components in list order too, but each target "
        "greedily; negative values are possible because the claiming mode may take "
        "any claimable component, not only the pointer's."
    )


def random_note(res: Results) -> str | None:
    """The settings where uniform random actions complete an episode."""
    rand = _run(res, "random")
    if not rand:
        return None
    ok = [k for k in rand if res.cells[(*k, "random")].summary["success_rate"] > 0]
    text = (
        f"**Random** (uniform over legal actions) completes at least one episode in "
        f"{len(ok)} of {len(rand)} settings"
    )
    if ok:
        text += ": " + ", ".join(f"{s} with {cranes(n)}" for s, n in ok)
    return text + "."


def timing_note(res: Results) -> str | None:
    """The prioritized planner's planning time, on hall-4c with 4 cranes, and its counters."""
    timing = _run(res, "prioritized")
    if not timing:
        return None
    summaries = {k: res.cells[(*k, "prioritized")].summary for k in timing}
    worst = max(timing, key=lambda k: summaries[k]["plan_ms_per_step"])
    s = summaries[worst]
    slowest = max(summaries[k]["plan_ms_max"] for k in timing)
    text = (
        f"**Planning time.** The prioritized planner's highest mean per joint decision is "
        f"{s['plan_ms_per_step']:.2f} ms ({worst[0]} with {worst[1]} cranes), its slowest "
        f"single call {slowest:.1f} ms; most decisions only read the next step of each "
        "plan, the searches happen at claims (one A* per claimed component) and replans."
    )
    if ("hall-4c", 4, "prioritized") in res.cells:
        h = res.cells[("hall-4c", 4, "prioritized")].summary
        text += (
            f" On hall-4c with 4 cranes: {h['plan_ms_per_step']:.2f} ms per joint decision, "
            f"{h['plan_ms_per_crane']:.2f} ms per crane decision, slowest call "
            f"{h['plan_ms_max']:.1f} ms (requirement: well under 50 ms)."
        )
    cells = [res.cells[(*k, "prioritized")] for k in timing]
    stats = {key: sum(c.stats.get(key, 0) for c in cells) for key in STAT_KEYS}
    return text + (
        f" Over all its episodes: {stats['searches']} searches ({stats['failed']} failed, "
        f"{stats['expansions']} states expanded), {stats['replans']} full replans, "
        f"{stats['repairs']} path repairs, {stats['fallbacks']} mask fallbacks."
    )


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
