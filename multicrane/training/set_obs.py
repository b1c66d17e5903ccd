"""Fixed-shape set observations: task observations of sites of any size padded to one shape.

A set-based policy reads the component, crane and task tables of the task-level observation
(``multicrane.envs.task_observation``) as sets. SB3 needs one observation shape and one action
count per vector environment, so every site's tables are padded to ``SetLimits`` (at most
``components`` C, ``cranes`` N and ``tasks`` P rows) and a three-number header says how many
rows of each are real:

    [C_real, N_real, P_real] + components (C x (21 + N)) + cranes (N x 10) + tasks (P x 9)

row major. Padding rows are zeros; the component table's ``reach_k`` columns are padded from
the site's cranes to N. A site exactly at the limits gives the header followed by the
environment's own flat observation, unchanged. Actions are ``1 + P`` (wait, then task ``p``);
a padded task is never allowed (``pad_mask``).

With site events (``SetLimits.events``; ``docs/uncertainty.md``) each component row gains a
last column ``delivered`` (after the N padded reach columns) and each crane row a last column
``available``: C x (21 + N + 1) and N x 11. The task observation's ``closed`` (X, Y) block has
no fixed shape across sites and is left out: closed zones reach the policy through the task
mask (a task through a closed cell is not allowed) and the ``target_ready``/``claimable``
columns. A site without events padded to limits with events shows every component delivered
and every crane available (what a static site is); a site with events does not fit limits
without them (the policy could not see the events): ``check`` says so.

With the planner's hint (``SetLimits.hint``, ``multicrane train --planner-hint``) each task row
gains a last column ``proposed``: 1 on the task the prioritized planner would start for the
observing crane in this round (``multicrane.tasks.priority_rule.proposals``, a dry run that
changes nothing), 0 elsewhere (all 0: the planner would have the crane wait). The policy then
learns when and where to depart from the planner rather than the planner itself; the padder
needs the environment to ask it (``Padder(..., env=env)``).

With the support graph (``SetLimits.graph``, ``multicrane train --graph-features``) each task
row gains two last columns (after ``proposed`` if both): ``chain``, the longest chain of
targets standing on the task's target divided by the site's longest, and ``dependents``, the
targets that need it assembled first, directly or not, divided by the site's targets less one
(``multicrane.tasks.support_graph``; 0 and 0 for a target nothing waits on). The flat
observation shows the supports only as coordinates; these say what a target holds up, which
is what critical-path rules rank by. The padder reads them from the environment's site.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from multicrane.envs.task_observation import (
    COMPONENT_FEATURES,
    CRANE_FEATURES,
    TASK_FEATURES,
    TaskLayout,
)
from multicrane.sim.simulator import NOBODY
from multicrane.tasks.priority_rule import list_ranks, proposals
from multicrane.tasks.support_graph import site_chains

N_COMP = len(COMPONENT_FEATURES)
N_CRANE = len(CRANE_FEATURES)
N_TASK = len(TASK_FEATURES)
HEADER = 3
GRAPH_FEATURES = ("chain", "dependents")


@dataclass(frozen=True)
class SetLimits:
    """The padded table sizes of a vector environment: rows of components, cranes, tasks."""

    components: int
    cranes: int
    tasks: int
    events: bool = False  # the delivered / available columns of sites with events
    hint: bool = False  # the tasks' ``proposed`` column (the planner's choice; module doc)
    graph: bool = False  # the tasks' ``chain`` and ``dependents`` columns (module doc)

    def __post_init__(self) -> None:
        for name in ("components", "cranes", "tasks"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < 1:
                raise ValueError(f"SetLimits.{name}={value!r}: must be a positive integer")
        for name in ("events", "hint", "graph"):
            value = getattr(self, name)
            if not isinstance(value, bool):
                raise ValueError(f"SetLimits.{name}={value!r}: must be True or False")

    @classmethod
    def of(cls, layout: TaskLayout) -> SetLimits:
        """The limits that fit one site exactly."""
        return cls(layout.n_components, layout.n_cranes, layout.n_tasks, _has_events(layout))

    def fits(self, layout: TaskLayout) -> bool:
        return (
            layout.n_components <= self.components
            and layout.n_cranes <= self.cranes
            and layout.n_tasks <= self.tasks
            and layout.plan is None
            and (self.events or not _has_events(layout))
        )

    def check(self, layout: TaskLayout, where: str = "site") -> None:
        """Raise a ValueError naming the table that does not fit."""
        if layout.plan is not None:
            raise ValueError(f"{where}: set observations do not take the site planes")
        if _has_events(layout) and not self.events:
            raise ValueError(
                f"{where}: the site has site events (events=...) but the set policy's limits "
                "have no event columns (delivered, available): train it with events (multicrane "
                "train --events LEVEL) or play it on a site without events (--events omitted on "
                "a scenario without an [events] table)"
            )
        for name, have, limit in (
            ("components", layout.n_components, self.components),
            ("cranes", layout.n_cranes, self.cranes),
            ("tasks", layout.n_tasks, self.tasks),
        ):
            if have > limit:
                raise ValueError(f"{where}: {have} {name} exceed the policy's limit of {limit}")

    @property
    def comp_width(self) -> int:
        return N_COMP + self.cranes + self.events

    @property
    def crane_width(self) -> int:
        return N_CRANE + self.events

    @property
    def task_width(self) -> int:
        return N_TASK + self.hint + len(GRAPH_FEATURES) * self.graph

    @property
    def size(self) -> int:
        return (
            HEADER
            + self.components * self.comp_width
            + self.cranes * self.crane_width
            + self.tasks * self.task_width
        )

    @property
    def n_actions(self) -> int:
        return 1 + self.tasks

    def slices(self) -> dict[str, tuple[int, int, tuple[int, int]]]:
        """``name -> (start, stop, (rows, features))`` of each table in the padded vector."""
        out, at = {}, HEADER
        for name, shape in (
            ("components", (self.components, self.comp_width)),
            ("cranes", (self.cranes, self.crane_width)),
            ("tasks", (self.tasks, self.task_width)),
        ):
            n = shape[0] * shape[1]
            out[name] = (at, at + n, shape)
            at += n
        return out

    def to_dict(self) -> dict[str, int]:
        """The sizes (and ``events``, ``hint`` or ``graph: True`` only when on, so limits
        without them keep the dict of older runs)."""
        out = {"components": self.components, "cranes": self.cranes, "tasks": self.tasks}
        for name in ("events", "hint", "graph"):
            if getattr(self, name):
                out[name] = True
        return out


def _has_events(layout) -> bool:
    return getattr(layout, "events", None) is not None


def union(layouts, hint: bool = False, graph: bool = False) -> SetLimits:
    """The smallest limits that fit every one of ``layouts`` (with event columns if any has
    them; with the hint column if ``hint``, the support graph's if ``graph``)."""
    layouts = list(layouts)
    if not layouts:
        raise ValueError("union of no layouts")
    return SetLimits(
        max(x.n_components for x in layouts),
        max(x.n_cranes for x in layouts),
        max(x.n_tasks for x in layouts),
        any(_has_events(x) for x in layouts),
        hint,
        graph,
    )


class Padder:
    """Pads the flat task observations of one site (``layout``) to ``limits``; with the hint
    column, ``env`` (the site's task-mode ``MultiCraneEnv``) is asked for the planner's
    proposals (``proposals()``, then each crane's ``pad(..., proposed=p)``); with the support
    graph's columns, its site is read once."""

    def __init__(self, layout: TaskLayout, limits: SetLimits, env=None):
        limits.check(layout)
        if (limits.hint or limits.graph) and env is None:
            what = "the planner's hint" if limits.hint else "the support graph's columns"
            raise ValueError(f"set limits with {what} need the environment: "
                             "Padder(layout, limits, env=env)")  # fmt: skip
        env = getattr(env, "unwrapped", env)
        self.layout, self.limits, self.env = layout, limits, env
        if limits.hint:
            self._list_rank = list_ranks(env.scenario)
        C, N, P = layout.n_components, layout.n_cranes, layout.n_tasks
        ev = _has_events(layout)
        self.exact = SetLimits.of(layout) == limits and not ev
        # Index map: destination positions of the source vector's entries, built once.
        sl = limits.slices()
        c0, cw = sl["components"][0], limits.comp_width
        rows = c0 + np.arange(C)[:, None] * cw
        cols = np.arange(N_COMP + N)
        if ev:  # the delivered column goes last, after the padded reach columns
            cols = np.append(cols, cw - 1)
        comp_dst = (rows + cols[None, :]).ravel()
        k0, kw = sl["cranes"][0], limits.crane_width
        crane_dst = (k0 + np.arange(N)[:, None] * kw + np.arange(N_CRANE + ev)[None, :]).ravel()
        t0, tw = sl["tasks"][0], limits.task_width
        self.hint_at = t0 + N_TASK + np.arange(P) * tw  # the proposed column of each task
        task_dst = (t0 + np.arange(P)[:, None] * tw + np.arange(N_TASK)[None, :]).ravel()
        self.dst = np.concatenate([comp_dst, crane_dst, task_dst])
        # A site without events under limits with events: all delivered, all available.
        self.ones = np.zeros(0, dtype=np.int64)
        if limits.events and not ev:
            self.ones = np.concatenate(
                [rows[:, 0] + cw - 1, k0 + np.arange(N) * kw + kw - 1]
            ).astype(np.int64)
        self.header = np.array([C, N, P], dtype=np.float32)
        self.graph_at, self.graph = _graph_columns(env, limits, t0, tw, P)

    def proposals(self) -> list[int]:
        """Per crane, the task the prioritized planner would start for it now (``NOBODY``:
        none); every one ``NOBODY`` without the hint column."""
        if not self.limits.hint:
            return [NOBODY] * self.layout.n_cranes
        book = self.env.mode.task_book()
        return proposals(book, self._list_rank)

    def pad(self, obs: np.ndarray, out: np.ndarray | None = None, proposed: int = NOBODY
            ) -> np.ndarray:  # fmt: skip
        """The padded vector of one flat observation (written into ``out`` if given);
        ``proposed``: the planner's task for the observing crane (the hint column)."""
        if out is None:
            out = np.zeros(self.limits.size, dtype=np.float32)
        else:
            out[:] = 0.0
        out[:HEADER] = self.header
        if self.exact:
            out[HEADER:] = obs
        else:
            out[self.dst] = obs[: len(self.dst)]  # (a closed block after the tasks: left out)
            out[self.ones] = 1.0
        if proposed != NOBODY:
            out[self.hint_at[proposed]] = 1.0
        if self.limits.graph:
            out[self.graph_at] = self.graph
        return out

    def pad_mask(self, mask: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """The action mask padded to ``1 + limits.tasks`` (padded tasks never allowed)."""
        if out is None:
            out = np.zeros(self.limits.n_actions, dtype=bool)
        else:
            out[:] = False
        out[: len(mask)] = mask
        return out


def _graph_columns(env, limits: SetLimits, t0: int, tw: int, P: int):
    """``(positions, values)`` of the support graph's task columns in the padded vector
    (empty without them): each task's target's ``chain`` and ``dependents`` (module doc)."""
    if not limits.graph:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.float32)
    site = env.sim.site
    chain, dependents = site_chains(site)
    per_target = np.stack([chain / max(int(chain.max(initial=0)), 1),
                           dependents / max(len(dependents) - 1, 1)], axis=1)  # fmt: skip
    targets = np.array([t for _, t in env.mode.task_book().tasks.pairs], dtype=np.int64)
    first = t0 + N_TASK + limits.hint
    at = first + np.arange(P)[:, None] * tw + np.arange(len(GRAPH_FEATURES))[None, :]
    return at.ravel(), per_target[targets].astype(np.float32).ravel()
