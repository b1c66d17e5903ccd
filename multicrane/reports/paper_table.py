"""Reference returns for the 16 configurations of the paper's benchmark, beside Table I.

For each configuration (E1S1 .. E4S4, ``PaperAssemblyEnv``) three policies handed in by the
caller (``optimal``: an exact planner, ``greedy``, ``random``, each as
``make_policy(env, seed)``) play the episodes that ``reset(seed=s)`` starts, through
``multicrane.episodes.rollout.evaluate``. A ``Row`` holds their returns, success rates and steps
beside
the best entry of the paper's Table I and the gap between that entry and the optimum (Table I
- optimum; negative is below it). E3S4's PPO entry is printed "140.18" in the paper; its minus
sign was lost and it is read as -140.18. ``text_table`` prints the rows; ``paper_page`` writes
the markdown page.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from multicrane.benchmark.reference import ALGORITHMS, SIGN_FIXED, TABLE_I
from multicrane.envs.paper_env import PaperAssemblyEnv
from multicrane.episodes.rollout import evaluate
from multicrane.stats import sem

POLICIES = ("optimal", "greedy", "random")
SAME = 1e-9  # returns closer than this are equal


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
    def sem(self) -> float | None:
        """Standard error of the mean over episodes (None for a single episode)."""
        return sem(self.returns)


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


def policy_stats(env: PaperAssemblyEnv, make_policy: Callable, seeds: range) -> Stats:
    """Run one policy over the episode seeds."""
    start = time.perf_counter()
    episodes, _ = evaluate(env, make_policy, list(seeds))
    return Stats(
        returns=tuple(float(e["return"]) for e in episodes),
        success=sum(bool(e["success"]) for e in episodes) / len(episodes),
        steps=statistics.fmean(e["steps"] for e in episodes),
        seconds=time.perf_counter() - start,
    )


def evaluate_config(
    config: str,
    policies: Mapping[str, Callable],
    seeds: range,
    advance: Callable[[int], None] | None = None,
) -> Row:
    """One configuration: ``policies`` maps optimal, greedy and random to their makers."""
    env = PaperAssemblyEnv(config)
    stats = {}
    for name in POLICIES:
        stats[name] = policy_stats(env, policies[name], seeds)
        if advance is not None:
            advance(len(seeds))
    return Row(config, **stats)


# -- text table ----------------------------------------------------------------------------------


def pm(mean: float, error: float | None) -> str:
    """mean ± standard error ("-" for none)."""
    return f"{mean:.2f} ± {'-' if error is None else f'{error:.2f}'}"


def paper_entry(row: Row) -> str:
    """The best Table I entry, its mark and its algorithm."""
    algo, mean, sem = row.best_entry
    mark = "*" if row.config in SIGN_FIXED else ""
    return f"{pm(mean, sem)}{mark} ({algo})"


def seed_range(seeds: range) -> str:
    return f"seeds {seeds.start}..{seeds.stop - 1}"


def timing(rows: list[Row], wall: float) -> str:
    parts = ", ".join(
        f"{name} {sum(getattr(r, name).seconds for r in rows):.1f} s" for name in POLICIES
    )
    return f"Total wall time {wall:.1f} s ({parts})."


def cells(r: Row) -> list[str]:
    """One configuration's columns: config, then return, success and steps of optimal, greedy
    and random, then the best Table I entry and the gap."""
    out = [r.config]
    for st in (r.optimal, r.greedy, r.random):
        out += [pm(st.mean, st.sem), f"{st.success:.0%}", f"{st.steps:.1f}"]
    return [*out, paper_entry(r), f"{r.gap:.2f}"]


def text_table(rows: list[Row], seeds: range, wall: float) -> str:
    """The rows as a plain-text table."""
    head = (
        f"{'config':<6} {'optimal':>16} {'ok':>5} {'steps':>6} | {'greedy':>16} {'ok':>5}"
        f" {'steps':>6} | {'random':>18} {'ok':>5} {'steps':>6} | {'Table I best':<28}"
        f" {'gap':>8}"
    )
    lines = [
        f"{len(seeds)} episodes per configuration, {seed_range(seeds)}; "
        "return = mean ± s.e. over episodes, ok = success rate, gap = Table I best - optimal",
        head,
        "-" * len(head),
    ]
    for r in rows:
        c = cells(r)
        lines.append(
            f"{c[0]:<6} {c[1]:>16} {c[2]:>5} {c[3]:>6} | {c[4]:>16} {c[5]:>5} {c[6]:>6} | "
            f"{c[7]:>18} {c[8]:>5} {c[9]:>6} | {c[10]:<28} {c[11]:>8}"
        )
    if any(r.config in SIGN_FIXED for r in rows):
        lines.append('* printed as "140.18" in the paper; the minus sign was lost')
    lines.append(timing(rows, wall))
    return "\n".join(lines) + "\n"
