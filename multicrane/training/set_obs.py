"""Fixed-shape set observations: task observations of sites of any size padded to one shape.

A set-based policy reads the component, crane and task tables of the task-level observation
(``multicrane.task_observation``) as sets. SB3 needs one observation shape and one action
count per vector environment, so every site's tables are padded to ``SetLimits`` (at most
``components`` C, ``cranes`` N and ``tasks`` P rows) and a three-number header says how many
rows of each are real:

    [C_real, N_real, P_real] + components (C x (21 + N)) + cranes (N x 10) + tasks (P x 9)

row major. Padding rows are zeros; the component table's ``reach_k`` columns are padded from
the site's cranes to N. A site exactly at the limits gives the header followed by the
environment's own flat observation, unchanged. Actions are ``1 + P`` (wait, then task ``p``);
a padded task is never allowed (``pad_mask``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from multicrane.task_observation import (
    COMPONENT_FEATURES,
    CRANE_FEATURES,
    TASK_FEATURES,
    TaskLayout,
)

N_COMP = len(COMPONENT_FEATURES)
N_CRANE = len(CRANE_FEATURES)
N_TASK = len(TASK_FEATURES)
HEADER = 3


@dataclass(frozen=True)
class SetLimits:
    """The padded table sizes of a vector environment: rows of components, cranes, tasks."""

    components: int
    cranes: int
    tasks: int

    def __post_init__(self) -> None:
        for name in ("components", "cranes", "tasks"):
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < 1:
                raise ValueError(f"SetLimits.{name}={value!r}: must be a positive integer")

    @classmethod
    def of(cls, layout: TaskLayout) -> SetLimits:
        """The limits that fit one site exactly."""
        return cls(layout.n_components, layout.n_cranes, layout.n_tasks)

    def fits(self, layout: TaskLayout) -> bool:
        return (
            layout.n_components <= self.components
            and layout.n_cranes <= self.cranes
            and layout.n_tasks <= self.tasks
            and layout.plan is None
        )

    def check(self, layout: TaskLayout, where: str = "site") -> None:
        """Raise a ValueError naming the table that does not fit."""
        if layout.plan is not None:
            raise ValueError(f"{where}: set observations do not take the site planes")
        for name, have, limit in (
            ("components", layout.n_components, self.components),
            ("cranes", layout.n_cranes, self.cranes),
            ("tasks", layout.n_tasks, self.tasks),
        ):
            if have > limit:
                raise ValueError(f"{where}: {have} {name} exceed the policy's limit of {limit}")

    @property
    def comp_width(self) -> int:
        return N_COMP + self.cranes

    @property
    def size(self) -> int:
        return (
            HEADER + self.components * self.comp_width + self.cranes * N_CRANE + self.tasks * N_TASK
        )

    @property
    def n_actions(self) -> int:
        return 1 + self.tasks

    def slices(self) -> dict[str, tuple[int, int, tuple[int, int]]]:
        """``name -> (start, stop, (rows, features))`` of each table in the padded vector."""
        out, at = {}, HEADER
        for name, shape in (
            ("components", (self.components, self.comp_width)),
            ("cranes", (self.cranes, N_CRANE)),
            ("tasks", (self.tasks, N_TASK)),
        ):
            n = shape[0] * shape[1]
            out[name] = (at, at + n, shape)
            at += n
        return out

    def to_dict(self) -> dict[str, int]:
        return {"components": self.components, "cranes": self.cranes, "tasks": self.tasks}


def union(layouts) -> SetLimits:
    """The smallest limits that fit every one of ``layouts``."""
    layouts = list(layouts)
    if not layouts:
        raise ValueError("union of no layouts")
    return SetLimits(
        max(x.n_components for x in layouts),
        max(x.n_cranes for x in layouts),
        max(x.n_tasks for x in layouts),
    )


class Padder:
    """Pads the flat task observations of one site (``layout``) to ``limits``."""

    def __init__(self, layout: TaskLayout, limits: SetLimits):
        limits.check(layout)
        self.layout, self.limits = layout, limits
        C, N, P = layout.n_components, layout.n_cranes, layout.n_tasks
        self.exact = SetLimits.of(layout) == limits
        # Index map: destination positions of the source vector's entries, built once.
        sl = limits.slices()
        c0 = sl["components"][0]
        comp_dst = (
            c0 + np.arange(C)[:, None] * limits.comp_width + np.arange(N_COMP + N)[None, :]
        ).ravel()
        k0 = sl["cranes"][0]
        crane_dst = k0 + np.arange(N * N_CRANE)
        t0 = sl["tasks"][0]
        task_dst = t0 + np.arange(P * N_TASK)
        self.dst = np.concatenate([comp_dst, crane_dst, task_dst])
        self.header = np.array([C, N, P], dtype=np.float32)

    def pad(self, obs: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """The padded vector of one flat observation (written into ``out`` if given)."""
        if out is None:
            out = np.zeros(self.limits.size, dtype=np.float32)
        else:
            out[:] = 0.0
        out[:HEADER] = self.header
        if self.exact:
            out[HEADER:] = obs
        else:
            out[self.dst] = obs
        return out

    def pad_mask(self, mask: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """The action mask padded to ``1 + limits.tasks`` (padded tasks never allowed)."""
        if out is None:
            out = np.zeros(self.limits.n_actions, dtype=bool)
        else:
            out[:] = False
        out[: len(mask)] = mask
        return out
