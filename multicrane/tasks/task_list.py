"""The task list: every (component, target) pair numbered, and the exclusive claims of a round.

``TaskList`` numbers the tasks of a site component-major (component 0's targets first, each in
target order): task ``p`` is the action ``1 + p`` of the task-level environment
(``multicrane.tasks.book``). In one round the cranes choose one after the other, and a task
chosen takes its component and its target from the later cranes (``exclusive_round``,
``exclusive_masks``: the masks as each crane saw them, for the learned policies and the
imitation of a teacher).
"""

from __future__ import annotations

import numpy as np

from multicrane.sim.simulator import Simulator


class TaskList:
    """Every (component, compatible target) pair of a site, component-major."""

    def __init__(self, sim: Simulator):
        site = sim.site
        self.pairs = [(c, t) for c in range(site.n_components) for t in site.compatible[c]]
        self.index = {pair: p for p, pair in enumerate(self.pairs)}
        self.comp = np.array([c for c, _ in self.pairs], dtype=np.int64)
        self.target = np.array([t for _, t in self.pairs], dtype=np.int64)
        self._by_component: dict[int, tuple[list[int], list[int]]] | None = None

    def __len__(self) -> int:
        return len(self.pairs)

    def by_component(self) -> dict[int, tuple[list[int], list[int]]]:
        """Per component with tasks: its tasks' indices and their targets, in task order."""
        if self._by_component is None:
            out: dict[int, tuple[list[int], list[int]]] = {}
            for p, (c, t) in enumerate(self.pairs):
                tasks, targets = out.setdefault(c, ([], []))
                tasks.append(p)
                targets.append(t)
            self._by_component = out
        return self._by_component

    def conflicts(self, p: int) -> np.ndarray:
        """The tasks that share task ``p``'s component or target (``p`` among them): once a
        crane chooses ``p`` in a round, the others are refused to later cranes."""
        return (self.comp == self.comp[p]) | (self.target == self.target[p])


def exclusive_round(masks: np.ndarray, tasks: TaskList, choose) -> tuple[np.ndarray, np.ndarray]:
    """A round's crane rows deciding one after the other (``masks``: rows x (1 + padded
    tasks), crane order; action 0 waits, ``1 + p`` is task ``p``): ``choose(k, mask)`` gives
    row ``k``'s action under the mask left to it; each task chosen removes the tasks it
    conflicts with (``TaskList.conflicts``) from the later rows' masks, and a choice its mask
    no longer allows becomes 0 (the environment would refuse it: the crane waits). Returns
    (the masks as each row saw them, the actions)."""
    out = np.array(masks, dtype=bool)
    chosen = np.zeros(len(out), dtype=np.int64)
    n = len(tasks)
    for k in range(len(out)):
        a = int(choose(k, out[k]))
        if a > 0 and out[k, a]:
            chosen[k] = a
            out[k + 1 :, 1 : n + 1] &= ~tasks.conflicts(a - 1)
    return out, chosen


def exclusive_masks(masks: np.ndarray, choices, tasks: TaskList):
    """(masks, choices) of a round's crane rows with the given ``choices`` (a teacher's) as
    the cranes see them deciding one after the other (``exclusive_round``)."""
    choices = np.asarray(choices, dtype=np.int64)
    return exclusive_round(masks, tasks, lambda k, mask: choices[k])


def task_list(env) -> TaskList | None:
    """The site's ``TaskList`` of a task-level environment (None at the motion level)."""
    mode = getattr(getattr(env, "unwrapped", env), "mode", None)
    return mode.task_book().tasks if getattr(mode, "task_level", False) else None
