"""Learned policies over training seeds beside planners and the bound, on the same episodes.

Input: the rows ``multicrane evaluate --json`` writes (per policy: its name, summary and
episodes; every policy plays the same reset seeds; a run directory is labelled ``ALGO (DIR)``).
Run directories named ``PREFIX-sN`` (one training seed each) are pooled into one learned entry
``ALGO (PREFIX)``: each seed's mean makespan over its finished episodes, then the mean over
seeds with the Student-t 95 % interval over seeds (``multicrane.stats.ci95``: seeds, not
episodes, are the independent samples). A planner's row, and a learned entry of one seed, is
the mean over its episodes, with the interval over episodes. Beside them:
how many seeds finished every episode, the share of (seed, episode) pairs where the learned
policy is shorter than the baseline planner on the same reset seed, and, when per-episode
lower bounds are given, each row's gap to the mean bound.
"""

from __future__ import annotations

import re
import statistics
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import multicrane.tables as tables
from multicrane.stats import ci95

_SEED_SUFFIX = re.compile(r"^(?P<prefix>.+)-s(?P<seed>\d+)$")
_RUN_LABEL = re.compile(r"^(?P<algo>[^()]+) \((?P<run>[^()]+)\)$")  # evaluate's "ALGO (DIR)"


@dataclass
class Entry:
    """One row: a planner (one 'seed'), or a learned policy pooled over training seeds."""

    name: str
    seeds: list[str] = field(default_factory=list)  # the evaluated policies' names
    makespans: list[list[int | None]] = field(default_factory=list)  # per seed, per episode
    learned: bool = False

    @property
    def per_seed(self) -> list[float | None]:
        """Each seed's mean makespan over its finished episodes (None: none finished)."""
        out = []
        for spans in self.makespans:
            done = [m for m in spans if m is not None]
            out.append(statistics.fmean(done) if done else None)
        return out

    @property
    def finished(self) -> int:
        return sum(m is not None for spans in self.makespans for m in spans)

    @property
    def episodes(self) -> int:
        return sum(len(spans) for spans in self.makespans)

    @property
    def seeds_all_finished(self) -> int:
        return sum(all(m is not None for m in spans) for spans in self.makespans)

    @property
    def samples(self) -> list[float]:
        """What the mean and interval are over: training seeds (a learned entry of several)
        or episodes (a planner, or one training seed)."""
        if self.learned and len(self.seeds) > 1:
            return [m for m in self.per_seed if m is not None]
        return [float(m) for m in self.makespans[0] if m is not None]

    @property
    def mean(self) -> float | None:
        xs = self.samples
        return statistics.fmean(xs) if xs else None

    @property
    def ci(self) -> tuple[float, float] | None:
        return ci95(self.samples)


def entries(rows: Sequence[Mapping]) -> list[Entry]:
    """The rows of ``multicrane evaluate --json`` as entries; ``PREFIX-sN`` run directories
    pooled by prefix (in order of first appearance). Every row must play the same seeds."""
    seeds = None
    out: dict[str, Entry] = {}
    for row in rows:
        name = str(row["policy"])
        eps = row["episodes"]
        these = [e["seed"] for e in eps]
        if seeds is None:
            seeds = these
        elif these != seeds:
            raise ValueError(f"policy {name!r} played reset seeds {these[:3]}..., "
                             f"the first policy {seeds[:3]}...: not the same episodes")  # fmt: skip
        spans = [e["makespan"] if e["success"] else None for e in eps]
        label = _RUN_LABEL.match(name)
        # a policy with options (``NAME:KEY=VALUE,...``; e.g. a search guided by a run
        # directory) groups by the whole text, its run's seed suffix at the end
        stem = label["run"] if label else name if ":" in name else name.rstrip("/").split("/")[-1]
        match = _SEED_SUFFIX.match(stem)
        key = match["prefix"] if match else name
        if label and match:
            key = f"{label['algo']} ({key})"
        entry = out.setdefault(key, Entry(key, learned=bool(match or label)))
        entry.seeds.append(name)
        entry.makespans.append(spans)
    return list(out.values())


def shorter_share(entry: Entry, baseline: Entry) -> tuple[int, int, int]:
    """(shorter, equal, pairs): the learned entry's (seed, episode) pairs against the
    baseline's makespan on the same episode; a pair counts only if both finished."""
    base = baseline.makespans[0]
    shorter = equal = pairs = 0
    for spans in entry.makespans:
        for m, b in zip(spans, base, strict=True):
            if m is None or b is None:
                continue
            pairs += 1
            shorter += m < b
            equal += m == b
    return shorter, equal, pairs


def episode_ratio(entry: Entry, baseline: Entry) -> float | None:
    """The mean over (seed, episode) pairs where both finished of the entry's makespan over
    the baseline's on the same episode (None: no such pair); on a set of sites of different
    sizes this weighs every site alike, where the ratio of the means favours the big ones."""
    base = baseline.makespans[0]
    ratios = [
        m / b
        for spans in entry.makespans
        for m, b in zip(spans, base, strict=True)
        if m is not None and b is not None
    ]
    return statistics.fmean(ratios) if ratios else None


def markdown_table(
    entries_: Sequence[Entry], baseline: str = "prioritized", bounds: Sequence[int] | None = None
) -> str:
    """One line per entry: mean makespan [95 % interval], finished episodes, seeds that
    finished every episode, per-seed means, ratio to the baseline, shorter than the baseline,
    and the gap to the mean lower bound when ``bounds`` (one per episode) are given."""
    base = next((e for e in entries_ if e.name == baseline), None)
    bound = statistics.fmean(bounds) if bounds else None
    head = ["policy", "mean makespan [95 % interval]", "finished", "seeds finishing all",
            "per training seed", f"/ {baseline} (mean of per-episode ratios)",
            f"shorter than {baseline}"]  # fmt: skip
    if bound is not None:
        head.append(f"gap to bound ({bound:.1f})")
    rows = [entry_cells(e, base, bound) for e in entries_]
    return "\n".join(tables.markdown_table(head, rows, align="l" * len(head)))


def entry_cells(e: Entry, base: Entry | None, bound: float | None) -> list[str]:
    """One entry's row of ``markdown_table`` (``base``: the baseline entry, if it was run)."""
    mean, ci = e.mean, e.ci
    cells = [
        e.name + (f" ({len(e.seeds)} seed{'s' if len(e.seeds) > 1 else ''})" if e.learned else ""),
        "-" if mean is None else f"{mean:.1f}" + (f" [{ci[0]:.1f}, {ci[1]:.1f}]" if ci else ""),
        f"{e.finished}/{e.episodes}",
        f"{e.seeds_all_finished}/{len(e.seeds)}" if e.learned else "",
        ", ".join("-" if m is None else f"{m:.1f}" for m in e.per_seed) if e.learned else "",
    ]
    ratio = ""
    if base is not None and base.mean is not None and mean is not None:
        ratio = f"{mean / base.mean:.3f} ({episode_ratio(e, base):.3f})"
    cells.append(ratio)
    if e.learned and base is not None:
        s, q, n = shorter_share(e, base)
        cells.append(f"{s}/{n}" + (f" ({q} equal)" if q else ""))
    else:
        cells.append("")
    if bound is not None:
        cells.append("" if mean is None else f"{100 * (mean - bound) / bound:+.1f} %")
    return cells
