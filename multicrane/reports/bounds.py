"""The makespan lower bound beside a policy's makespan, for scenarios x crane counts.

``bound_rows`` computes ``multicrane.bounds.makespan.lower_bound`` for each (scenario, crane count)
and,
if a policy is handed in (``make_policy(env, seed)``, e.g. ``policies.make`` bound to a name),
plays the episode ``reset(seed=seed)`` starts (the same start the bound is for) through
``multicrane.episodes.rollout.run_episode``; ``text_table`` and ``markdown_table`` format the rows
with
the gap ``(makespan - bound) / bound``. ``multicrane bound`` prints them.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass

import multicrane.tables as tables
from multicrane.bounds.makespan import BoundResult, lower_bound
from multicrane.core.schema import Scenario

MakePolicy = Callable[..., Callable]


@dataclass(frozen=True)
class Row:
    """One (scenario, crane count): the bound and, if a policy ran, its makespan."""

    bound: BoundResult
    policy: str | None = None
    makespan: int | None = None  # None: no policy, or it did not finish

    @property
    def gap(self) -> float | None:
        """(makespan - bound) / bound, or None."""
        if self.makespan is None or self.bound.value <= 0:
            return None
        return (self.makespan - self.bound.value) / self.bound.value

    def as_dict(self) -> dict:
        out = self.bound.as_dict()
        if self.policy is not None:
            out.update(policy=self.policy, makespan=self.makespan, gap=self.gap)
        return out


def bound_row(
    scenario: str | Scenario,
    n_cranes: int | None,
    seed: int = 0,
    make_policy: MakePolicy | None = None,
    policy: str | None = None,
    time_limit: float = 60.0,
    workers: int = 2,
) -> Row:
    """The bound for one (scenario, crane count) and, with ``make_policy``, its makespan."""
    from multicrane.envs.crane_env import MultiCraneEnv
    from multicrane.episodes.rollout import run_episode

    bound = lower_bound(scenario, n_cranes, seed=seed, time_limit=time_limit, workers=workers)
    if make_policy is None:
        return Row(bound)
    env = MultiCraneEnv(scenario, n_cranes=bound.n_cranes)
    result = run_episode(env, make_policy(env, seed), seed=seed)
    return Row(bound, policy, result["makespan"])


def bound_rows(
    scenarios: Iterable[str | Scenario],
    cranes: Iterable[int],
    seed: int = 0,
    make_policy: MakePolicy | None = None,
    policy: str | None = None,
    time_limit: float = 60.0,
    workers: int = 2,
) -> list[Row]:
    """``bound_row`` for every scenario x crane count, scenario by scenario."""
    cranes = list(cranes)
    return [
        bound_row(s, n, seed, make_policy, policy, time_limit, workers)
        for s in scenarios
        for n in cranes
    ]


HEAD = ["scenario", "cranes", "bound", "status", "solve s", "tasks"]


def _cells(row: Row, with_policy: bool) -> list[str]:
    b = row.bound
    cells = [b.scenario, str(b.n_cranes), str(b.value), b.status, f"{b.wall_s:.2f}"]
    cells.append(str(b.n_tasks))
    if with_policy:
        cells.append("-" if row.makespan is None else str(row.makespan))
        cells.append("-" if row.gap is None else f"{row.gap:.1%}")
    return cells


def _head(rows: list[Row]) -> tuple[list[str], bool]:
    policy = next((r.policy for r in rows if r.policy is not None), None)
    if policy is None:
        return list(HEAD), False
    return [*HEAD, f"{policy} makespan", "gap"], True


def text_table(rows: list[Row]) -> str:
    """The rows as aligned text columns."""
    head, with_policy = _head(rows)
    return tables.text_table(head, [_cells(r, with_policy) for r in rows])


def markdown_table(rows: list[Row]) -> str:
    """The rows as a markdown table."""
    head, with_policy = _head(rows)
    return "\n".join(tables.markdown_table(head, [_cells(r, with_policy) for r in rows]))
