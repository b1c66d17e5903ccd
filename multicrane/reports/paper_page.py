"""The markdown page of the paper's reference returns: provenance, table and observations.

``multicrane paper-table --markdown`` writes it (``docs/paper-results.md``). The page is built
from tables: its prose (the caveat, what each column holds) is the data below, its table the
rows of ``paper_table.cells`` laid out by ``multicrane.tables``.
"""

from __future__ import annotations

import datetime

from multicrane.benchmark.reference import ALGORITHMS, SIGN_FIXED, TABLE_I
from multicrane.reports.paper_table import POLICIES, SAME, Row, cells, seed_range, timing
from multicrane.reports.provenance import machine
from multicrane.tables import markdown_table


def observations(rows: list[Row]) -> list[str]:
    """Statements read off the numbers (each only about the configurations that were run)."""
    by_env: dict[str, list[Row]] = {}
    for r in rows:
        by_env.setdefault(r.config[:2], []).append(r)
    return [gap_note(rows, by_env), optimal_note(rows), greedy_note(rows),
            random_note(rows, by_env)]  # fmt: skip


def gap_note(rows: list[Row], by_env: dict[str, list[Row]]) -> str:
    """How far the best Table I entry lies below our optimum, per environment."""
    gaps = []
    for env, rs in by_env.items():
        lo, hi = min(-r.gap for r in rs), max(-r.gap for r in rs)
        span = f"{lo:.2f}" if abs(hi - lo) < 0.005 else f"{lo:.2f} to {hi:.2f}"
        gaps.append(f"Env{env[1]} by {span}")
    below = all(r.gap < 0 for r in rows)
    text = "**Best Table I entry vs. our optimum.** " + (
        "The best entry lies below our mean optimal return in every configuration: "
        if below
        else "The best entry lies below our mean optimal return (negative: above it): "
    )
    text += "; ".join(gaps) + "."
    worst = {env: max(-r.gap for r in rs) for env, rs in by_env.items()}
    if len(worst) > 1 and list(worst.values()) == sorted(worst.values()):
        envs = list(worst)
        text += f" The largest gap per environment grows from Env{envs[0][1]} to Env{envs[-1][1]}."
    return text + (
        " Part of each gap may come from the environment rather than the agent (Table I's "
        "episodes could be cut short or be impossible to finish; see `paper-differences.md`)."
    )


def optimal_note(rows: list[Row]) -> str:
    """The episodes the exact planner finishes, fixed starts, and S4 beside S2."""
    by_config = {r.config: r for r in rows}
    n_episodes = sum(len(r.optimal.returns) for r in rows)
    n_finished = sum(round(r.optimal.success * len(r.optimal.returns)) for r in rows)
    text = f"**Optimal.** The planner finishes {n_finished} of the {n_episodes} episodes" + (
        ": no drawn layout is impossible to finish." if n_finished == n_episodes else "."
    )
    fixed = [r.config for r in rows if r.optimal.sem == 0 and len(r.optimal.returns) > 1]
    if fixed:
        text += (
            f" The optimal return is the same in every episode of {', '.join(fixed)} (fixed "
            "starts, nothing drawn at reset), hence a standard error of 0."
        )
    pairs = [
        (f"E{e}S2", f"E{e}S4")
        for e in range(1, 5)
        if f"E{e}S2" in by_config and f"E{e}S4" in by_config
    ]
    same = [
        f"{s2}/{s4}"
        for s2, s4 in pairs
        if abs(by_config[s2].optimal.mean - by_config[s4].optimal.mean) < SAME
    ]
    if same:
        text += (
            f" S4 has exactly the same mean optimal return as S2 in {', '.join(same)}: there "
            "the obstacles do not lengthen the optimal paths (measured in "
            "`paper-differences.md`, item 2)."
        )
    return text


def greedy_note(rows: list[Row]) -> str:
    """Where greedy gets the optimal return in every episode, and where it falls short."""
    every = [r.config for r in rows if r.greedy_optimal_episodes == len(r.greedy.returns)]
    some = [r for r in rows if r.config not in every]
    text = "**Greedy vs. optimal.** "
    if every:
        text += f"Greedy gets the optimal return in every episode of {', '.join(every)}. "
    if some:
        text += (
            "It falls short in "
            + "; ".join(
                f"{r.config} (optimal in {r.greedy_optimal_episodes}/{len(r.greedy.returns)}"
                f" episodes, mean {r.optimal.mean - r.greedy.mean:.2f} below the optimum)"
                for r in some
            )
            + ". "
        )
        s1 = [r for r in rows if r.config.endswith("S1")]
        if s1 and all(r.config in every for r in s1):
            text += (
                "So greedy is optimal in every S1 configuration (each component has its own "
                "target), and all its shortfalls are in configurations with interchangeable "
                "targets, where the nearest target is not always the best choice."
            )
    return text.strip()


def random_note(rows: list[Row], by_env: dict[str, list[Row]]) -> str:
    """Where uniform random actions finish an episode, and Table I entries at or below them."""
    if all(r.random.success == 0 for r in rows):
        n_episodes = sum(len(r.optimal.returns) for r in rows)
        text = (
            f"**Random.** Uniform random actions finish none of the {n_episodes} episodes, in "
            "any configuration; every random episode runs to the step limit."
        )
    else:
        rates = "; ".join(
            f"Env{env[1]} " + ", ".join(f"{r.config[2:]} {r.random.success:.0%}" for r in rs)
            for env, rs in by_env.items()
        )
        text = f"**Random.** Uniform random actions finish an episode in: {rates}."
    under = [
        f"{r.config} {algo} ({m:.2f}, our random {r.random.mean:.2f})"
        for r in rows
        for algo, (m, _) in zip(ALGORITHMS, TABLE_I[r.config], strict=True)
        if m <= r.random.mean
    ]
    if under:
        return text + " Table I entries at or below our random mean: " + "; ".join(under) + "."
    return text + " Every Table I entry is above our random mean."


TITLE = "# Reference returns for the paper's 16 configurations"

INTRO = (
    "What an exact planner, a greedy planner and uniform random actions achieve in each "
    "configuration of the paper's single-agent benchmark (`multicrane.PaperAssemblyEnv`, "
    "E1S1 .. E4S4), beside the best entry of the paper's Table I."
)

CAVEAT = (
    "**These returns come from the corrected environment** (see "
    "[paper-spec.md](paper-spec.md) and [paper-differences.md](paper-differences.md)). Table I "
    "was produced by the paper's public code, whose episodes could be cut short, whose "
    "obstacles blocked nothing and whose E4S1/E4S3 episodes were mostly impossible to "
    "finish, so its numbers are not directly comparable with ours: the gap column says "
    "how far an entry lies below the best return achievable in our environment, not how "
    "good the paper's agents were in theirs."
)

COLUMNS = (  # what the columns hold, one list item each
    "*optimal return*: `multicrane.bounds.paper_optimum.plan`, the exact best return of "
    "each episode, "
    "mean ± standard error over episodes; *optimal success*: share of episodes it "
    "finishes; *optimal steps*: mean length of the optimal episodes.",
    "*greedy*: `policies.paper_greedy.PaperGreedyPolicy` (the current component takes "
    "a shortest path to the nearest free target it can fill): return mean ± s.e., "
    "success rate, mean steps.",
    "*random*: uniform over the six actions (no mask), from its own generator seeded "
    "per episode with (seed, 1): return mean ± s.e., success rate, mean steps (episodes "
    "that do not finish run to the step limit: 100, 300, 600 for Env1/2, Env3, Env4).",
    "*Table I best (algorithm)*: the best of the paper's four entries (mean ± s.e. over "
    '15 training seeds) and which algorithm got it; the paper\'s "DQN" was a double DQN '
    'and its "DDQN" a dueling double DQN.',
    "*gap to optimum*: Table I best minus our mean optimal return (negative: below the "
    "optimum).",
)

HEAD = [
    "config",
    *(f"{policy} {what}" for policy in POLICIES for what in ("return", "success", "steps")),
    "Table I best (algorithm)",
    "gap to optimum",
]
ALIGN = "l" + "r" * 9 + "l"  # the Table I entry left-aligned, the gap right


def markdown_page(rows: list[Row], seeds: range, wall: float, command: str) -> str:
    """The whole page."""
    out = [TITLE, "", INTRO, "", CAVEAT, ""]
    out += [
        f"- Command: `{command}`.",
        f"- Date: {datetime.date.today().isoformat()}.",
        f"- Machine: {machine()}.",
        f"- Episodes: {len(seeds)} per configuration, {seed_range(seeds)} (passed to "
        "`reset(seed=...)`); the same seeds for all three policies.",
        f"- {timing(rows, wall)}",
        "",
    ]
    out += ["Columns:", "", *(f"- {text}" for text in COLUMNS), ""]
    out += markdown_table(HEAD, [cells(r) for r in rows], ALIGN)
    out.append("")
    if any(r.config in SIGN_FIXED for r in rows):
        out += ['\\* printed as "140.18" in the paper; the minus sign was lost.', ""]
    out += ["## Observations", ""]
    for note in observations(rows):
        out += [f"- {note}", ""]
    return "\n".join(out)
