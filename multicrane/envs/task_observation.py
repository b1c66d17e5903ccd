"""The task-level observation: component, crane and task tables for set-based policies.

One flat float32 vector in [0, 1] per crane, the concatenation of the tables below (row
major); ``TaskLayout.split(obs)`` returns them as ``(rows, features)`` arrays, so an
attention or pooling network can read any scenario size. ``X, Y, H`` is the site size;
positions are site coordinates divided by it; path lengths and times are divided by
``D = X + Y + H`` (path lengths) or ``D + assembly_steps + 1`` (times) and clipped to 1.

``components`` (C rows, scenario order; ``COMPONENT_FEATURES`` then one column per crane):
beam (its kind's ``beam_feature``, ``multicrane.core.kinds``: 1 for a beam, 0 for a column or
panel); status one-hot (initial, in transit, arrived,
assembled); node 1 and node 2 of its cells now (x, y, z each); node 1 and node 2 of its own
target; target_ready (its own target is free and its supports are assembled); claimable
(a crane could take it now); taken (it is some crane's task); path (shortest path length
through the static site from its pick-up pose to its nearest free compatible target, any
crane; 1 when none; 0 once lifted); reach_k (crane k can carry it to some target).

``cranes`` (N rows; ``CRANE_FEATURES``): self (this row is the observing crane); busy;
time_left (estimated steps until idle); loaded (holds a component); load node 1 (x, y, z;
0 when none); base x, base y and radius of its reach (radius / max(X, Y); all 0 without).

``tasks`` (P rows, the task numbering of ``multicrane.tasks.book``; ``TASK_FEATURES``):
component (its index / max(C - 1, 1)); target node 1 and node 2; distance (static path
length from the pick-up pose to the target for this crane, 1 when it cannot); allowed
(the action mask's entry ``1 + p`` for this crane).

With site events (``events=``, ``multicrane.sim.events``) only: ``components`` gains a last column
``delivered`` (a component not yet delivered has only that, 0, and its target columns), ``cranes``
a last column ``available`` (not broken down), and a ``closed`` block (X, Y) holds the height
of the highest closed cell above each (x, y), divided by H.

``planes`` (only with ``task_site_planes=True``): the (X, Y, 9) site planes of the motion
observation (``multicrane.envs.observation``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from multicrane.core.codes import Status
from multicrane.core.kinds import kind_spec
from multicrane.envs.observation import N_OWN, N_SHARED, Observer
from multicrane.sim.simulator import NOBODY
from multicrane.tasks.book import TaskBook

COMPONENT_FEATURES = (
    "beam", "initial", "in_transit", "arrived", "assembled",
    "x1", "y1", "z1", "x2", "y2", "z2", "tx1", "ty1", "tz1", "tx2", "ty2", "tz2",
    "target_ready", "claimable", "taken", "path",
)  # fmt: skip
CRANE_FEATURES = (
    "self", "busy", "time_left", "loaded", "lx", "ly", "lz", "base_x", "base_y", "radius",
)  # fmt: skip
TASK_FEATURES = ("component", "tx1", "ty1", "tz1", "tx2", "ty2", "tz2", "distance", "allowed")
_INITIAL = int(Status.INITIAL)


@dataclass(frozen=True)
class TaskLayout:
    """Where each table lies in the flat task observation."""

    n_components: int
    n_cranes: int
    n_tasks: int
    plan: tuple[int, int] | None = None  # (X, Y) when the site planes are included
    events: tuple[int, int] | None = None  # (X, Y) with site events

    def blocks(self) -> list[tuple[str, tuple[int, ...]]]:
        e = int(self.events is not None)
        out = [
            ("components", (self.n_components, len(COMPONENT_FEATURES) + self.n_cranes + e)),
            ("cranes", (self.n_cranes, len(CRANE_FEATURES) + e)),
            ("tasks", (self.n_tasks, len(TASK_FEATURES))),
        ]
        if self.events is not None:
            out.append(("closed", self.events))
        if self.plan is not None:
            out.append(("planes", (self.plan[0], self.plan[1], N_SHARED + N_OWN)))
        return out

    @property
    def size(self) -> int:
        return sum(int(np.prod(shape)) for _, shape in self.blocks())

    def split(self, obs: np.ndarray) -> dict[str, np.ndarray]:
        """The flat vector as named tables: ``components`` (C, 21 + N), ``cranes`` (N, 10),
        ``tasks`` (P, 9) and, if included, ``planes`` (X, Y, 9)."""
        out, at = {}, 0
        for name, shape in self.blocks():
            n = int(np.prod(shape))
            out[name] = obs[at : at + n].reshape(shape)
            at += n
        return out


class TaskObserver:
    """Builds the task observation of every crane from the simulator and the task book."""

    def __init__(self, book: TaskBook, site_planes: bool = False):
        self.book = book
        sim = book.sim
        self.sim = sim
        X, Y, H = sim.scenario.size
        self.scale = np.array([X, Y, H], dtype=np.float32)
        self.D = float(X + Y + H)
        self.T_norm = self.D + sim.scenario.assembly_steps + 1
        self.planes = Observer(sim) if site_planes else None
        self.layout = TaskLayout(
            sim.site.n_components,
            sim.n_cranes,
            len(book.tasks),
            (X, Y) if site_planes else None,
            (X, Y) if sim.events is not None else None,
        )
        site = sim.site
        self._beam = np.array([kind_spec(k).beam_feature for k in site.kind], dtype=bool)
        self._targets = np.array(
            [self._nodes(cells) for cells in site.target_cells], dtype=np.float32
        ).reshape(site.n_components, 6)
        self._reach = np.zeros((sim.n_cranes, 3), dtype=np.float32)
        specs = sim.scenario.crane_specs
        if specs:
            for k in range(sim.n_cranes):
                (bx, by), r = specs[k].base, specs[k].radius
                self._reach[k] = (bx / X, by / Y, min(r / max(X, Y), 1.0))

    def _nodes(self, cells: list[int]) -> list[float]:
        site = self.sim.site
        a = np.array(site.cell(cells[0]), dtype=np.float32) / self.scale
        b = np.array(site.cell(cells[-1]), dtype=np.float32) / self.scale
        return [*a, *b]

    def reset(self, step_limit: int) -> None:
        if self.planes is not None:
            self.planes.reset(step_limit)

    def _closed_plan(self) -> np.ndarray:
        """(X * Y,) the top closed height per (x, y) column, divided by H."""
        sim = self.sim
        X, Y, H = sim.scenario.size
        closed = sim.closed.reshape(sim.site.shape)[1 : X + 1, 1 : Y + 1, 1 : H + 1]
        z = np.arange(1, H + 1, dtype=np.float32) / H
        return (closed * z).max(axis=2).reshape(-1)

    def observe_all(self) -> list[np.ndarray]:
        """One flat observation per crane, in crane order."""
        sim, book = self.sim, self.book
        comp = self._component_rows()
        cranes = self._crane_rows()
        C, N = sim.site.n_components, sim.n_cranes
        P = len(book.tasks)
        tasks = np.zeros((P, len(TASK_FEATURES)), dtype=np.float32)
        tasks[:, 0] = book.tasks.comp / max(C - 1, 1)
        tasks[:, 1:7] = self._targets[book.tasks.target]
        dist = np.where(book.static_ok, np.minimum(book.static_len / self.D, 1.0), 1.0)
        masks = book.masks()
        head = [comp.ravel(), None, None]
        closed = self._closed_plan() if self.layout.events is not None else None
        if self.planes is not None:
            self.planes.update(sim.take_changed(), sim.claimable_components())
        out = []
        for k in range(N):
            cr = cranes.copy()
            cr[k, 0] = 1.0
            tk = tasks.copy()
            tk[:, 7] = dist[k]
            tk[:, 8] = masks[k, 1:]
            head[1], head[2] = cr.ravel(), tk.ravel()
            parts = list(head)
            if closed is not None:
                parts.append(closed)
            if self.planes is not None:
                parts.append(self._site_planes(k))
            out.append(np.concatenate(parts).astype(np.float32, copy=False))
        self.masks = masks
        return out

    def _component_rows(self) -> np.ndarray:
        """The ``components`` table, shared by every crane."""
        sim, book = self.sim, self.book
        st = sim.state
        C, N = sim.site.n_components, sim.n_cranes
        events = self.layout.events is not None
        comp = np.zeros((C, len(COMPONENT_FEATURES) + N + events), dtype=np.float32)
        status = np.asarray(st.status)
        comp[:, 0] = self._beam
        comp[np.arange(C), 1 + status] = 1.0
        for c in range(C):
            cells = st.cells[c] if st.cells[c] else st.pickup[c]
            if cells:
                comp[c, 5:11] = self._nodes(cells)
        comp[:, 11:17] = self._targets
        comp[:, 17] = sim.target_ready
        comp[sim.claimable_components(), 18] = 1.0
        for p in book.task:
            if p != NOBODY:
                comp[book.tasks.comp[p], 19] = 1.0
        lens = np.where(book.static_ok, book.static_len, np.iinfo(np.int64).max)
        free_t = np.asarray(st.filled_by) == NOBODY
        best = np.full(C, np.inf)
        pair_len = lens.min(axis=0).astype(np.float64)
        pair_len[~free_t[book.tasks.target]] = np.inf
        np.minimum.at(best, book.tasks.comp, pair_len)
        path = np.where(np.isfinite(best), np.minimum(best / self.D, 1.0), 1.0)
        path[status != _INITIAL] = 0.0
        comp[:, 20] = path
        can = np.zeros((N, C), dtype=bool)
        for k in range(N):
            np.logical_or.at(can[k], book.tasks.comp, book.static_ok[k])
        comp[:, 21 : 21 + N] = can.T
        if events:
            late = ~np.asarray(st.delivered)
            comp[late, :11] = 0.0  # only "not delivered" (and its own target) is known
            comp[late, 17:] = 0.0
            comp[:, -1] = st.delivered
        return comp

    def _crane_rows(self) -> np.ndarray:
        """The ``cranes`` table without its ``self`` column (set per observing crane)."""
        sim, book, st = self.sim, self.book, self.sim.state
        N = sim.n_cranes
        events = self.layout.events is not None
        cranes = np.zeros((N, len(CRANE_FEATURES) + events), dtype=np.float32)
        for k in range(N):
            cranes[k, 1] = book.busy(k)
            cranes[k, 2] = min(book.time_left(k) / self.T_norm, 1.0)
            held = st.held[k]
            if held != NOBODY and st.cells[held]:
                cranes[k, 3] = 1.0
                cranes[k, 4:7] = self._nodes(st.cells[held])[:3]
        cranes[:, 7:10] = self._reach
        if events:
            cranes[:, -1] = [sim.crane_up(k) for k in range(N)]
        return cranes

    def _site_planes(self, crane: int) -> np.ndarray:
        """The (X, Y, 9) site planes of the motion observation, flat."""
        full = self.planes.observe(crane)
        X, Y = self.layout.plan
        shared = full[self.planes.layout.shared].reshape(X, Y, N_SHARED)
        own = full[self.planes.layout.own].reshape(X, Y, N_OWN)
        return np.concatenate([shared, own], axis=-1).ravel()
