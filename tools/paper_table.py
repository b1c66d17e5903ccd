"""Reference returns for the 16 configurations of the paper's benchmark, beside Table I.

    python tools/paper_table.py                          # 100 episodes x 16 configurations
    python tools/paper_table.py --configs E1S1 E4S2 --episodes 20
    python tools/paper_table.py --markdown --output docs/paper-results.md

For each configuration ("E1S1" ... "E4S4", ``multicrane.PaperAssemblyEnv``) it plays the
episodes that ``reset(seed=first + i)`` starts, i = 0 .. N-1, with three policies:

- optimal: ``policies.optimal.plan``, the exact best return of each episode;
- greedy: ``policies.paper_greedy.PaperGreedyPolicy`` (shortest path to the nearest free
  target the current component can fill);
- random: uniform over the six actions (no mask), from its own generator, seeded per
  episode with (episode seed, 1) so that its stream differs from the layout's.

It prints the mean return +- standard error over episodes, the success rate and the mean
steps of each policy, the best entry of the paper's Table I for that configuration (with its
algorithm) and the gap between that entry and our optimum (Table I - optimum; negative is
below the optimum). Table I was produced by the paper's public code, which section 7 of
``paper-benchmark.md`` corrects, so that gap is indicative only. E3S4's PPO entry is printed
"140.18" in the paper; its minus sign was lost and it is read here as -140.18.

``--markdown`` prints a whole page (explanation, table, observations computed from the
numbers); without it, a text table. Progress goes to stderr.
"""

from __future__ import annotations

import argparse
import datetime
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from multicrane.benchmark.reference import ALGORITHMS, SIGN_FIXED, TABLE_I  # noqa: E402
from multicrane.optimal import plan  # noqa: E402
from multicrane.paper_env import PAPER_CONFIGS, PaperAssemblyEnv  # noqa: E402
from multicrane.rollout import run_episode  # noqa: E402
from policies import make  # noqa: E402
from tools.report import command_line, machine  # noqa: E402

SAME = 1e-9  # returns closer than this are equal

Episode = tuple[float, bool, int]  # return, success, steps


# -- evaluation --------------------------------------------------------------------------------


@dataclass(frozen=True)
class Stats:
    """One policy over the episodes of one configuration."""

    returns: tuple[float, ...]
    success: float
    steps: float
    seconds: float

    @property
    def mean(self) -> float:
        return statistics.fmean(self.returns)

    @property
    def sem(self) -> float:
        """Standard error of the mean over episodes (0 for a single episode)."""
        n = len(self.returns)
        return statistics.stdev(self.returns) / n**0.5 if n > 1 else 0.0


@dataclass(frozen=True)
class Row:
    """One configuration: the three policies and the paper's best Table I entry."""

    config: str
    optimal: Stats
    greedy: Stats
    random: Stats

    @property
    def best_entry(self) -> tuple[str, float, float]:
        """The best Table I entry: (algorithm(s), mean, standard error)."""
        entries = TABLE_I[self.config]
        best = max(m for m, _ in entries)
        names = [a for a, (m, _) in zip(ALGORITHMS, entries, strict=True) if m == best]
        return "/".join(names), best, entries[ALGORITHMS.index(names[0])][1]

    @property
    def gap(self) -> float:
        """Best Table I entry minus our mean optimal return."""
        return self.best_entry[1] - self.optimal.mean

    @property
    def greedy_optimal_episodes(self) -> int:
        """Episodes in which greedy got the optimal return."""
        pairs = zip(self.greedy.returns, self.optimal.returns, strict=True)
        return sum(abs(g - o) < SAME for g, o in pairs)


def optimal_episode(env: PaperAssemblyEnv, seed: int) -> Episode:
    env.reset(seed=seed)
    p = plan(env=env)
    return p.episode_return, p.success, p.steps


def played(name: str) -> Callable[[PaperAssemblyEnv, int], Episode]:
    """One episode of ``policies.make(name)`` (random: uniform over the six moves, no mask,
    from its own generator seeded with (seed, 1))."""

    def episode(env: PaperAssemblyEnv, seed: int) -> Episode:
        m = run_episode(env, make(name, env, seed), seed=seed)
        return m["return"], m["success"], m["steps"]

    return episode


POLICIES: dict[str, Callable[[PaperAssemblyEnv, int], Episode]] = {
    "optimal": optimal_episode,
    "greedy": played("greedy"),
    "random": played("random"),
}


def evaluate(
    env: PaperAssemblyEnv, episode: Callable[[PaperAssemblyEnv, int], Episode], seeds: range
) -> Stats:
    """Run one policy over the episode seeds."""
    start = time.perf_counter()
    results = [episode(env, seed) for seed in seeds]
    return Stats(
        returns=tuple(r for r, _, _ in results),
        success=sum(s for _, s, _ in results) / len(results),
        steps=statistics.fmean(n for _, _, n in results),
        seconds=time.perf_counter() - start,
    )


def evaluate_config(config: str, seeds: range) -> Row:
    env = PaperAssemblyEnv(config)
    return Row(config, **{name: evaluate(env, fn, seeds) for name, fn in POLICIES.items()})


# -- text table ----------------------------------------------------------------------------------


def _pm(mean: float, sem: float) -> str:
    return f"{mean:.2f} ± {sem:.2f}"


def _paper(row: Row) -> str:
    algo, mean, sem = row.best_entry
    mark = "*" if row.config in SIGN_FIXED else ""
    return f"{_pm(mean, sem)}{mark} ({algo})"


def _seeds(args: argparse.Namespace) -> str:
    return f"seeds {args.seed}..{args.seed + args.episodes - 1}"


def _timing(rows: list[Row], wall: float) -> str:
    parts = ", ".join(
        f"{name} {sum(getattr(r, name).seconds for r in rows):.1f} s" for name in POLICIES
    )
    return f"Total wall time {wall:.1f} s ({parts})."


def text_table(rows: list[Row], args: argparse.Namespace, wall: float) -> str:
    head = (
        f"{'config':<6} {'optimal':>16} {'ok':>5} {'steps':>6} | {'greedy':>16} {'ok':>5}"
        f" {'steps':>6} | {'random':>18} {'ok':>5} {'steps':>6} | {'Table I best':<28}"
        f" {'gap':>8}"
    )
    lines = [
        f"{args.episodes} episodes per configuration, {_seeds(args)}; "
        "return = mean ± s.e. over episodes, ok = success rate, gap = Table I best - optimal",
        head,
        "-" * len(head),
    ]
    for r in rows:
        o, g, x = r.optimal, r.greedy, r.random
        lines.append(
            f"{r.config:<6} {_pm(o.mean, o.sem):>16} {o.success:>5.0%} {o.steps:>6.1f} | "
            f"{_pm(g.mean, g.sem):>16} {g.success:>5.0%} {g.steps:>6.1f} | "
            f"{_pm(x.mean, x.sem):>18} {x.success:>5.0%} {x.steps:>6.1f} | "
            f"{_paper(r):<28} {r.gap:>8.2f}"
        )
    if any(r.config in SIGN_FIXED for r in rows):
        lines.append('* printed as "140.18" in the paper; the minus sign was lost')
    lines.append(_timing(rows, wall))
    return "\n".join(lines) + "\n"


# -- markdown page -------------------------------------------------------------------------------


def _configs(rows: list[Row]) -> str:
    return ", ".join(r.config for r in rows) if rows else "none"


def observations(rows: list[Row]) -> list[str]:
    """Statements read off the numbers (each only about the configurations that were run)."""
    notes = []
    by_env: dict[str, list[Row]] = {}
    by_config = {r.config: r for r in rows}
    for r in rows:
        by_env.setdefault(r.config[:2], []).append(r)

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
    text += (
        " Part of each gap may come from the environment rather than the agent (Table I's "
        "episodes could be cut short or be impossible to finish; see `paper-differences.md`)."
    )
    notes.append(text)

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
    notes.append(text)

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
    notes.append(text.strip())

    if all(r.random.success == 0 for r in rows):
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
        text += " Table I entries at or below our random mean: " + "; ".join(under) + "."
    else:
        text += " Every Table I entry is above our random mean."
    notes.append(text)
    return notes


def markdown_page(
    rows: list[Row], args: argparse.Namespace, wall: float, argv: list[str] | None = None
) -> str:
    out = [
        "# Reference returns for the paper's 16 configurations",
        "",
        "What an exact planner, a greedy planner and uniform random actions achieve in each "
        "configuration of the paper's single-agent benchmark (`multicrane.PaperAssemblyEnv`, "
        "E1S1 .. E4S4), beside the best entry of the paper's Table I.",
        "",
        "**These returns come from the corrected environment** (section 7 of "
        "`paper-benchmark.md`; see [paper-differences.md](paper-differences.md)). Table I "
        "was produced by the paper's public code, whose episodes could be cut short, whose "
        "obstacles blocked nothing and whose E4S1/E4S3 episodes were mostly impossible to "
        "finish, so its numbers are not directly comparable with ours: the gap column says "
        "how far an entry lies below the best return achievable in our environment, not how "
        "good the paper's agents were in theirs.",
        "",
        f"- Command: `{command_line(__file__, argv)}` (from the repository root).",
        f"- Date: {datetime.date.today().isoformat()}.",
        f"- Machine: {machine()}.",
        f"- Episodes: {args.episodes} per configuration, {_seeds(args)} (passed to "
        "`reset(seed=...)`); the same seeds for all three policies.",
        f"- {_timing(rows, wall)}",
        "",
        "Columns:",
        "",
        "- *optimal return*: `policies.optimal.plan`, the exact best return of each episode, "
        "mean ± standard error over episodes; *optimal success*: share of episodes it "
        "finishes; *optimal steps*: mean length of the optimal episodes.",
        "- *greedy*: `policies.paper_greedy.PaperGreedyPolicy` (the current component takes "
        "a shortest path to the nearest free target it can fill): return mean ± s.e., "
        "success rate, mean steps.",
        "- *random*: uniform over the six actions (no mask), from its own generator seeded "
        "per episode with (seed, 1): return mean ± s.e., success rate, mean steps (episodes "
        "that do not finish run to the step limit: 100, 300, 600 for Env1/2, Env3, Env4).",
        "- *Table I best (algorithm)*: the best of the paper's four entries (mean ± s.e. over "
        '15 training seeds) and which algorithm got it; the paper\'s "DQN" was a double DQN '
        'and its "DDQN" a dueling double DQN.',
        "- *gap to optimum*: Table I best minus our mean optimal return (negative: below the "
        "optimum).",
        "",
        "| config | optimal return | optimal success | optimal steps | greedy return "
        "| greedy success | greedy steps | random return | random success | random steps "
        "| Table I best (algorithm) | gap to optimum |",
        "|---|" + "---:|" * 9 + "---|---:|",
    ]
    for r in rows:
        o, g, x = r.optimal, r.greedy, r.random
        out.append(
            f"| {r.config} | {_pm(o.mean, o.sem)} | {o.success:.0%} | {o.steps:.1f} "
            f"| {_pm(g.mean, g.sem)} | {g.success:.0%} | {g.steps:.1f} "
            f"| {_pm(x.mean, x.sem)} | {x.success:.0%} | {x.steps:.1f} "
            f"| {_paper(r)} | {r.gap:.2f} |"
        )
    out.append("")
    if any(r.config in SIGN_FIXED for r in rows):
        out += ['\\* printed as "140.18" in the paper; the minus sign was lost.', ""]
    out += ["## Observations", ""]
    for note in observations(rows):
        out += [f"- {note}", ""]
    return "\n".join(out)


# -- command line --------------------------------------------------------------------------------


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--episodes", type=int, default=100, help="episodes per configuration")
    p.add_argument(
        "--configs",
        nargs="+",
        default=list(PAPER_CONFIGS),
        type=str.upper,
        choices=PAPER_CONFIGS,
        metavar="CONFIG",
        help="configurations to run (default: all 16, E1S1 .. E4S4)",
    )
    p.add_argument("--seed", type=int, default=0, help="first episode seed")
    p.add_argument("--markdown", action="store_true", help="print a markdown page")
    p.add_argument("--output", type=Path, default=None, help="write to this file")
    args = p.parse_args(argv)
    if args.episodes < 1:
        p.error("--episodes must be at least 1")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    seeds = range(args.seed, args.seed + args.episodes)
    start = time.perf_counter()
    rows = []
    for config in args.configs:
        rows.append(evaluate_config(config, seeds))
        print(f"{config} done ({time.perf_counter() - start:.1f} s)", file=sys.stderr)
    wall = time.perf_counter() - start
    if args.markdown:
        text = markdown_page(rows, args, wall, argv)
    else:
        text = text_table(rows, args, wall)
    if args.output is not None:
        args.output.write_text(text, encoding="utf-8")
        print(f"wrote {args.output}", file=sys.stderr)
    else:
        print(text, end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
