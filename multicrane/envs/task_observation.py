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

from multicrane.core.kinds import kind_spec
from multicrane.envs.observation import N_OWN, N_SHARED, Observer
from multicrane.envs.task_observation_kernel import component_rows_kernel
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


@dataclass(frozen=True)
class EpisodeColumns:
    """The observation's columns that only the episode's static path lengths decide."""

    tasks: np.ndarray  # (N, P, 9) every crane's ``tasks`` table but its ``allowed`` column
    pair_len: np.ndarray  # (P,) the task's shortest static path over the cranes (inf: none)
    reach: np.ndarray  # (C, N) crane k can carry the component to some target

    @classmethod
    def of(cls, static_len: np.ndarray, static_ok: np.ndarray, task_comp: np.ndarray, C: int,
           D: float, task_base: np.ndarray) -> EpisodeColumns:  # fmt: skip
        """The columns of an episode's static path lengths (``TaskBook.static_len``)."""
        lens = np.where(static_ok, static_len, np.iinfo(np.int64).max)
        N = static_ok.shape[0]
        can = np.zeros((N, C), dtype=bool)
        for k in range(N):
            np.logical_or.at(can[k], task_comp, static_ok[k])
        tasks = np.repeat(task_base[None], N, axis=0)
        tasks[:, :, 7] = np.where(static_ok, np.minimum(static_len / D, 1.0), 1.0)
        return cls(tasks, lens.min(axis=0).astype(np.float64), np.ascontiguousarray(can.T))


class TaskObserver:
    """Builds the task observation of every crane from the simulator and the task book.

    What a site fixes (coordinates of every cell, the targets' nodes, the tasks' own
    columns) is computed once; what an episode fixes (the static path lengths: the tasks'
    distances, the components' best path and reach columns) once per episode, at the first
    observation after ``reset``; each observation then writes every crane's row of one
    array."""

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
        self._coords = self._cell_coordinates()
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
        tasks = book.tasks
        C = site.n_components
        self._task_base = np.zeros((len(tasks), len(TASK_FEATURES)), dtype=np.float32)
        self._task_base[:, 0] = tasks.comp / max(C - 1, 1)
        self._task_base[:, 1:7] = self._targets[tasks.target]
        self._episode: EpisodeColumns | None = None
        self._size = self.layout.size

    def _cell_coordinates(self) -> np.ndarray:
        """(cells, 3) float32: each linear index's site cell (``Site.cell``) / the site size."""
        cells = self.sim.site.grid_coords() - np.array([1, 1, 0])  # padded -> site cells
        return cells.astype(np.float32) / self.scale

    def _nodes(self, cells: list[int]) -> np.ndarray:
        """Node 1 and node 2 (x, y, z each, divided by the site size) of a pose's cells."""
        return np.concatenate([self._coords[cells[0]], self._coords[cells[-1]]])

    def reset(self, step_limit: int) -> None:
        if self.planes is not None:
            self.planes.reset(step_limit)
        self._episode = None  # the task book's static paths are drawn after this reset

    def _closed_plan(self) -> np.ndarray:
        """(X * Y,) the top closed height per (x, y) column, divided by H."""
        sim = self.sim
        X, Y, H = sim.scenario.size
        closed = sim.closed.reshape(sim.site.shape)[1 : X + 1, 1 : Y + 1, 1 : H + 1]
        z = np.arange(1, H + 1, dtype=np.float32) / H
        return (closed * z).max(axis=2).reshape(-1)

    def observe_all(self) -> list[np.ndarray]:
        """One flat observation per crane, in crane order (the rows of one fresh array)."""
        sim, book = self.sim, self.book
        if self._episode is None:
            self._start_episode()
        comp = self._component_rows()
        cranes = self._crane_rows()
        masks = book.masks()
        closed = self._closed_plan() if self.layout.events is not None else None
        planes = None
        if self.planes is not None:
            self.planes.update(sim.take_changed(), sim.claimable_components())
            planes = [self._site_planes(k) for k in range(sim.n_cranes)]
        self._read = (comp, cranes, masks, book.idle_cranes(), closed, planes)
        self.masks = masks
        return list(self.last_rows())

    def last_rows(self, out: np.ndarray | None = None) -> np.ndarray:
        """The rows ``observe_all`` last returned, built again (into ``out`` when given,
        else a fresh array) from what it read, as they were returned."""
        comp, cranes, masks, idle, closed, planes = self._read
        N, P = self.sim.n_cranes, len(self.book.tasks)
        if out is None:
            out = self._template.copy()  # the tasks tables but "allowed", the "self" flags
        else:
            out[:] = self._template
        at = comp.size + cranes.size
        out[:, : comp.size] = comp.ravel()
        out[:, comp.size : at] += cranes.ravel()  # (the template holds only the "self" flags)
        tasks = out[:, at : at + self._task_base.size].reshape(N, P, len(TASK_FEATURES))
        if idle:  # a busy crane's row allows nothing: the template's zeros
            tasks[idle, :, 8] = masks[idle, 1:]
        at += self._task_base.size
        if closed is not None:
            out[:, at : at + closed.size] = closed
            at += closed.size
        if planes is not None:
            for k in range(N):
                out[k, at:] = planes[k]
        return out

    def episode_columns(self, static_len: np.ndarray, static_ok: np.ndarray) -> EpisodeColumns:
        """The columns an episode's static path lengths decide (``TaskBook.static_len`` and
        ``static_ok``; the task vector env's copies too)."""
        C = self.sim.site.n_components
        return EpisodeColumns.of(static_len, static_ok, self.book.tasks.comp, C, self.D,
                                 self._task_base)  # fmt: skip

    def site_tables(self) -> dict:
        """What a site fixes of the observation, for the task vector env's compiler: each
        cell's coordinates / the site size (``cell_xyz``), the beam flags, the targets' nodes,
        each crane's reach row, the divisors ``D`` and ``T_norm``, and the vector's size."""
        return {"cell_xyz": self._coords, "beam": self._beam, "target_nodes": self._targets,
                "reach_row": self._reach, "D": self.D, "T_norm": self.T_norm,
                "obs_size": self.layout.size}  # fmt: skip

    def _start_episode(self) -> None:
        """The episode's columns (``EpisodeColumns``), an observation template holding them
        and each crane's "self" flag, and the cell poses seen so far (none)."""
        book, N = self.book, self.sim.n_cranes
        self._episode = self.episode_columns(book.static_len, book.static_ok)
        shapes = dict(self.layout.blocks())
        comp_size = int(np.prod(shapes["components"]))
        n_crane = shapes["cranes"][1]
        self._template = np.zeros((N, self._size), dtype=np.float32)
        self._template[np.arange(N), comp_size + np.arange(N) * n_crane] = 1.0  # self
        at = comp_size + N * n_crane
        self._template[:, at : at + self._task_base.size] = self._episode.tasks.reshape(N, -1)
        C = self.sim.site.n_components
        self._first, self._last = np.full(C, -1, np.int64), np.full(C, -1, np.int64)
        self._seen: list = [None] * C  # the cell list each pose was read from

    def _component_rows(self) -> np.ndarray:
        """The ``components`` table, shared by every crane (``component_rows_kernel``)."""
        sim, book = self.sim, self.book
        st = sim.state
        C, N = sim.site.n_components, sim.n_cranes
        events = self.layout.events is not None
        comp = np.zeros((C, len(COMPONENT_FEATURES) + N + events), dtype=np.float32)
        first, last, seen = self._first, self._last, self._seen
        for c, now in enumerate(st.cells):  # a move gives a component a new list, never edits
            if now is not seen[c]:
                seen[c] = now
                cells = now or st.pickup[c]
                first[c], last[c] = (cells[0], cells[-1]) if cells else (-1, -1)
        taken = [book.tasks.comp[p] for p in book.task if p != NOBODY]
        component_rows_kernel(
            comp, st.status, first, last, self._coords, self._beam, self._targets,
            np.asarray(sim.target_ready, dtype=np.bool_),
            np.asarray(sim.claimable_components(), dtype=np.int64),
            np.asarray(taken, dtype=np.int64), st.filled_by == NOBODY, book.tasks.comp,
            book.tasks.target, self._episode.pair_len, self._episode.reach, self.D, events,
            np.asarray(st.delivered, dtype=np.bool_), np.empty(C),
        )  # fmt: skip
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
                cranes[k, 4:7] = self._coords[st.cells[held][0]]
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
