"""The reservation table as flat rows for the compiled search: the carrier's table.

``ReservationArrays`` holds what ``multicrane.tasks.reservations.ReservationTable`` holds (a
cell is held by a component from one time to another, ``INF``: for ever) as rows
``(cell, from, to, component)`` of one int64 array, with the same methods, so the carrier
builds, copies and releases it alike; ``compiled_search`` is ``space_time_search`` (the
specification, in ``reservations``) run by ``multicrane.tasks.search_kernels``. Row order never
matters: a conflict is any row, the goal's free time the latest.
"""

from __future__ import annotations

import numpy as np

from multicrane.tasks.reservations import INF, Plan, fill_from_plans
from multicrane.tasks.search_kernels import (
    CELL,
    FROM,
    OWNER,
    TO,
    conflict_kernel,
    path_rows_kernel,
    space_time_search_into,
)
from multicrane.tasks.search_scratch import SearchScratch, grown_scratch, search_scratch


class ReservationArrays:
    """Reservation rows ``(cell, from, to, component)``; ``rows[:n]`` are in use."""

    def __init__(self, capacity: int = 256):
        self.rows = np.zeros((capacity, 4), dtype=np.int64)
        self.n = 0

    def __getitem__(self, cell: int) -> list[tuple[int, int, int]]:
        """The ``(from, to, component)`` intervals of ``cell``, as ``ReservationTable[cell]``
        (``KeyError`` when none)."""
        rows = self.rows[: self.n]
        held = rows[rows[:, CELL] == cell][:, [FROM, TO, OWNER]]
        if not len(held):
            raise KeyError(cell)
        return [tuple(r) for r in held.tolist()]

    def _room(self, more: int) -> None:
        """Grow the rows so that ``more`` fit after the ``n`` in use."""
        need = self.n + more
        if need > len(self.rows):
            grown = np.zeros((max(need, 2 * len(self.rows)), 4), dtype=np.int64)
            grown[: self.n] = self.rows[: self.n]
            self.rows = grown

    def hold(self, cells, start: int, end: int, comp: int) -> None:
        """``comp`` holds ``cells`` from ``start`` to ``end`` (``INF``: for ever)."""
        k = len(cells)
        if not k:
            return
        self._room(k)
        self.rows[self.n : self.n + k] = [(c, start, end, comp) for c in cells]
        self.n += k

    def reserve_path(
        self, comp: int, rel: tuple[int, ...], t0: int, positions: list[int], T: int
    ) -> None:
        """Reserve a path (``positions[i]`` at time ``t0 + i``) from time ``T`` on; the last
        position is held for ever."""
        self._room(len(positions) * len(rel))
        self.n = path_rows_kernel(
            self.rows, self.n, comp, np.asarray(rel, dtype=np.int64), t0,
            np.asarray(positions, dtype=np.int64), T, INF,
        )  # fmt: skip

    def reserve_plan(self, plan: Plan, rel: tuple[int, ...], T: int) -> None:
        self.reserve_path(plan.comp, rel, plan.t0, plan.positions, T)

    @classmethod
    def of_plans(cls, sim, plans: dict[int, Plan], T: int) -> ReservationArrays:
        """``ReservationTable.of_plans``: every plan's reservations from time ``T`` on."""
        return fill_from_plans(cls(), sim, plans, T)

    def release(self, comp: int) -> None:
        """Drop every reservation of ``comp``."""
        kept = self.rows[: self.n][self.rows[: self.n, OWNER] != comp]
        self.rows[: len(kept)] = kept
        self.n = len(kept)

    def conflict(self, cells, lo: int, hi: int, me: int) -> bool:
        """True when another component holds one of ``cells`` at some time in ``lo..hi``."""
        return conflict_kernel(self.rows, self.n, np.asarray(cells, dtype=np.int64), lo, hi, me)

    def copy(self) -> ReservationArrays:
        """An independent copy."""
        out = ReservationArrays(0)
        out.rows, out.n = self.rows[: max(self.n, 1)].copy(), self.n
        return out

    def replace_with(self, other: ReservationArrays) -> None:
        """Hold exactly ``other``'s reservations (this object stays the carrier's table)."""
        self.rows, self.n = other.rows.copy(), other.n


_KEPT: dict[int, SearchScratch] = {}  # positions -> the scratch this process's searches grew


def compiled_search(
    res: ReservationArrays,
    comp: int,
    rel: tuple[int, ...],
    start: int,
    t_start: int,
    goal: int,
    stops: set[int],
    site: tuple[np.ndarray, ...],
    oracle: np.ndarray,
    slack: int,
    max_expansions: int,
    lifted_onto_goal_arrives: bool = True,
) -> tuple[list[int] | None, int]:
    """``reservations.space_time_search`` (same answer) on the compiled kernel: ``site`` is
    ``(occ, status, static, reach, coords, deltas)`` (``ShapeCache.site_inputs``), from which
    the kernel reads the fit (``distance_oracle.fits_base``), and ``oracle`` gives the distances
    to the goal (``multicrane.tasks.distance_oracle``). The search runs in this process's kept
    scratch for the grid's size, grown until it fits (``multicrane.tasks.search_scratch``)."""
    occ, status, static, reach, coords, deltas = site
    stop = np.zeros(occ.size, dtype=np.bool_)
    if stops:
        stop[list(stops)] = True
    rel_a = np.asarray(rel, dtype=np.int64)
    scratch = _KEPT.get(occ.size) or search_scratch(occ.size)
    while True:
        length, expansions = space_time_search_into(
            res.rows, res.n, comp, rel_a, start, t_start, goal, stop, occ, status, static, reach,
            coords, deltas, oracle, slack, max_expansions, lifted_onto_goal_arrives, INF, scratch,
        )  # fmt: skip
        if length >= 0:
            break
        scratch = grown_scratch(scratch, length, res.n)
    _KEPT[occ.size] = scratch
    return (scratch.path[:length].tolist() if length else None), int(expansions)
