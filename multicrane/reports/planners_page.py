"""The planner comparison as a report: the markdown page and the plain-text report.

``multicrane compare-planners`` prints or writes it (``docs/planners.md``). The page is built
from tables: its prose (the policies, the definitions, each table's introduction, the
limitations) is the data below, its numbers are the rows of ``planners_tables`` laid out by
``multicrane.tables``, and its observations come from ``planners_notes``.
"""

from __future__ import annotations

import datetime
from collections.abc import Callable, Sequence
from typing import NamedTuple

from multicrane.reports.planners import Results
from multicrane.reports.planners_notes import observations
from multicrane.reports.planners_tables import (
    BOUND_HEAD,
    HEAD,
    TASK_HEAD,
    TIMING_HEAD,
    bound_rows,
    main_rows,
    speedup_head,
    speedup_rows,
    task_rows,
    timing_rows,
)
from multicrane.reports.provenance import machine
from multicrane.tables import markdown_table, text_table

TITLE = "# Classical multi-crane planners: the baselines RL must beat"

INTRO = (
    "What a greedy planner, a prioritized planner with space-time reservations and uniform "
    "random actions achieve on every shipped scenario with 1 to 4 cranes, in "
    "`MultiCraneEnv`'s default (claiming) mode, beside the single-agent optimum where it "
    "applies. A learned multi-crane policy should be compared with the *prioritized* "
    "column: it is what a good classical planner achieves on the same scenarios and seeds."
)

POLICIES = (  # (name, what it is): the page's list of policies
    ("greedy", "`policies.greedy.GreedyPolicy`. Each idle crane claims the ready "
     "component nearest to a target; the component follows a shortest path that treats every "
     "other component as a fixed obstacle; a blocked crane waits and replans, and after 3 "
     "blocked steps makes a random legal move."),
    ("prioritized", "`policies.prioritized.PrioritizedPlanner`. Cooperative A* in space "
     "and time for each rigid component against a reservation table of the paths already "
     "planned (a component never enters a cell another occupies in the same or the previous "
     "step, so plans hold whatever order the cranes act in), goals held for ever from the "
     "arrival, pick-up poses checked at the claim step; ready components claimed in the "
     "scenario's list order, each to the nearest free ready target, only when a full "
     "collision-free path exists; replanning when the site differs from the plan."),
    ("random", "`policies.random_policy.RandomPolicy`, uniform over the legal actions "
     "(seeded per episode with (seed, 1))."),
    ("optimal (auto) steps", "`multicrane.bounds.paper_optimum.plan(config, seed)`, the "
     "exact optimum "
     "of the paper's single-agent *automatic* mode for the same layouts (e?s? with one crane "
     "only). It is a different process: there the first move lifts the component and the "
     "arrival assembles it; here a claim step lifts it and an assemble step finishes it. "
     "The step counts are comparable but not identical in definition; *opt+2/comp* converts "
     "the optimum to the claiming mode's count (steps - pass-over steps + 2 x components "
     "assembled). The optimum maximises the paper's return, which for a fixed order means "
     "shortest paths; it is not a makespan bound for other component orders."),
)  # fmt: skip

DEFINITIONS = (  # (term, meaning): the page's definitions
    ("makespan", "joint steps (`env.step` calls) to complete the building, mean over the "
     "completed episodes, (min-max) when they differ; `-` when none completed."),
    ("ok", "completed episodes / episodes (within the scenario's step limit)."),
    ("blocked", "`BLOCKED` events per episode (moves refused because the cell was taken, "
     "e.g. by a component another crane moved earlier in the same step)."),
    ("prio vs greedy", "relative difference of the mean makespans (negative: prioritized "
     "finishes sooner)."),
    ("utilisation", "crane-steps in which a crane held a component (at the start or the "
     "end of the step: claiming, carrying, waiting loaded, assembling) over cranes x steps; "
     "the rest is idle time."),
    ("planning time per decision", "wall time inside the policy call per joint step (one "
     "call decides the actions of all cranes), and per crane decision (the same divided by "
     "the number of cranes); slowest call: the longest single call."),
)  # fmt: skip


class Table(NamedTuple):
    """A table section of the page, shown when it has rows."""

    title: str
    intro: str
    head: Callable[[Results], list[str]]
    rows: Callable[[Results], list[list[str]]]
    align: str  # ``multicrane.tables``: an ``l`` per left-aligned leading column
    in_text: bool  # also in the plain-text report


TABLES = (
    Table("Scaling with cranes (large scenarios)",
          "Mean makespan with n cranes (speed-up over one crane); utilisation per crane count.",
          speedup_head, speedup_rows, "ll", False),
    Table("Lower bound and gaps",
          "The makespan lower bound of each episode (`multicrane bound`, CP-SAT; "
          "[bound.md](bound.md) states the model and why it is a bound), mean over the "
          "planners' seeds; *proven*: seeds whose relaxation the solver solved to optimality; "
          "*gap*: (makespan - bound) / bound per completed episode, its own bound, mean over "
          "episodes. Part of every gap is the bound's (it ignores collisions between cranes).",
          lambda _: BOUND_HEAD, bound_rows, "ll", True),
    Table("Task mode (large scenarios)",
          "The prioritized rule as a task-level policy (`decisions=\"task\"`, "
          "[task-mode.md](task-mode.md)) on the same seeds: makespan, whether it equals the "
          "motion-mode planner's on every seed, decision rounds (`env.step` calls) per "
          "episode and wall time per round (the policy, the carrier's planning and the "
          "simulated steps together), beside motion mode's joint steps per episode and wall "
          "time per joint step (policy and environment).",
          lambda _: TASK_HEAD, task_rows, "ll", True),
    Table("Planning time per decision (large scenarios)",
          "Pooled over the episodes of each setting (total time in the policy over total "
          "joint steps); a shared 2-core machine, so figures vary by some tens of percent "
          "between runs.",
          lambda _: TIMING_HEAD, timing_rows, "lll", True),
)  # fmt: skip

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


def how_made(res: Results, command: str) -> list[str]:
    """The page's provenance: command, date, machine, episodes and wall time."""
    args = res.setup
    seeds = f"seeds {args.seed}..{args.seed + args.seeds - 1}"
    rseeds = (
        f"seeds {args.seed}..{args.seed + args.random_seeds - 1}" if args.random_seeds else "none"
    )
    return [
        f"- Command: `{command}`.",
        f"- Date: {datetime.date.today().isoformat()}.",
        f"- Machine: {machine()}.",
        f"- Episodes: greedy and prioritized {args.seeds} per setting ({seeds}, passed to "
        f"`reset(seed=...)`); random {args.random_seeds} per setting ({rseeds}; it mostly runs "
        "to the step limit); optimal on the planners' seeds.",
        f"- Total wall time {res.wall:.0f} s.",
    ]


def _section(title: str, lines: Sequence[str]) -> list[str]:
    return [f"## {title}", "", *lines, ""]


def _notes(notes: Sequence[str]) -> list[str]:
    return [line for note in notes for line in (f"- {note}", "")]


def _table_section(table: Table, res: Results) -> list[str]:
    rows = table.rows(res)
    if not rows:
        return []
    head = table.head(res)
    return ["", f"## {table.title}", "", table.intro, "", *markdown_table(head, rows, table.align)]


def markdown_page(res: Results, command: str) -> str:
    """The whole page: how it was made, the policies, definitions, tables, observations."""
    out = [TITLE, "", INTRO, "", *how_made(res, command), ""]
    out += _section("Policies", [f"- **{name}**: {text}" for name, text in POLICIES])
    out += _section("Definitions", [f"- *{term}*: {text}" for term, text in DEFINITIONS])
    out += ["## Makespan and success", "", *markdown_table(HEAD, main_rows(res))]
    for table in TABLES:
        out += _table_section(table, res)
    out += ["", "## Observations", "", *_notes(observations(res))]
    out += ["## Limitations of the prioritized planner", "", *_notes(LIMITATIONS)]
    return "\n".join(out)


def text_report(res: Results) -> str:
    """The tables and observations as plain text."""
    parts = [text_table(HEAD, main_rows(res), align="")]
    for table in TABLES:
        rows = table.rows(res) if table.in_text else []
        if rows:
            parts.append(text_table(table.head(res), rows, align=""))
    parts += [f"- {n}" for n in observations(res)]
    parts.append(f"Total wall time {res.wall:.1f} s.")
    return "\n\n".join(parts) + "\n"
