"""Exclusive claims in a task-level round: cranes decide in crane order, and a crane's task
removes from the later cranes' options every task that shares its component or target
(``TaskList.conflicts``, ``tasks.exclusive_masks``, ``model_policy.exclusive_actions``)."""

from __future__ import annotations

import numpy as np
import pytest

from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.envs.infos import TASK_EVENTS
from multicrane.tasks.task_list import exclusive_masks
from multicrane.training.model_policy import exclusive_actions


class _Tasks:
    """A TaskList of hand-picked (component, target) pairs."""

    def __init__(self, pairs):
        self.pairs = pairs
        self.comp = np.array([c for c, _ in pairs])
        self.target = np.array([t for _, t in pairs])

    def __len__(self):
        return len(self.pairs)

    def conflicts(self, p):
        return (self.comp == self.comp[p]) | (self.target == self.target[p])


# tasks: 0 = (c0, t0), 1 = (c0, t1), 2 = (c1, t0), 3 = (c1, t1), 4 = (c2, t2)
TASKS = _Tasks([(0, 0), (0, 1), (1, 0), (1, 1), (2, 2)])
ALL = np.ones((3, 1 + 5 + 2), dtype=bool)  # wait, 5 tasks, 2 padded columns
ALL[:, 6:] = False


@pytest.mark.parametrize(
    ("choices", "left", "chosen"),
    [
        # crane 0 takes (c0, t0): crane 1 keeps (c1, t1) and (c2, t2) only
        ([1, 4, 5], [[0, 1, 2, 3, 4], [3, 4], [4]], [1, 4, 5]),
        # crane 0 waits: nothing is removed for crane 1
        ([0, 2, 5], [[0, 1, 2, 3, 4], [0, 1, 2, 3, 4], [2, 4]], [0, 2, 5]),
        # crane 1 asks for what crane 0 took: refused (it waits) and removes nothing
        ([5, 5, 1], [[0, 1, 2, 3, 4], [0, 1, 2, 3], [0, 1, 2, 3]], [5, 0, 1]),
    ],
)
def test_exclusive_masks_table(choices, left, chosen):
    masks, out = exclusive_masks(ALL, choices, TASKS)
    assert [sorted(np.flatnonzero(m[1:6])) for m in masks] == left
    assert masks[:, 0].all() and not masks[:, 6:].any()  # wait stays; padding stays closed
    assert out.tolist() == chosen


def test_cranes_that_see_the_same_thing_take_different_tasks():
    scores = np.tile(np.array([0.0, 5, 4, 3, 2, 1, -1, -1]), (3, 1))
    actions = exclusive_actions(scores, ALL, TASKS)
    assert actions.tolist() == [1, 4, 5]  # (c0, t0), then (c1, t1), then (c2, t2)
    naive = np.where(ALL, scores, -np.inf).argmax(1)
    assert naive.tolist() == [1, 1, 1]  # what a row-by-row argmax would send (two refused)


def test_the_real_first_round_of_a_site():
    env = MultiCraneEnv("frame2-3c", n_cranes=4, decisions="task")
    obs, _ = env.reset(seed=0)
    masks = np.stack([obs[a]["action_mask"] for a in env.possible_agents])
    scores = np.zeros(masks.shape)  # every crane indifferent between tasks: the first one
    scores[:, 0] = -1.0
    tasks = env.mode.task_book().tasks
    actions = exclusive_actions(scores, masks, tasks)
    chosen = [tasks.pairs[a - 1] for a in actions if a > 0]
    assert len(chosen) == len({c for c, _ in chosen}) == len({t for _, t in chosen}) > 1
    _, _, _, _, infos = env.step(dict(zip(env.possible_agents, actions.tolist(), strict=True)))
    refused = TASK_EVENTS.index("TASK_REFUSED")
    assert all(info["task_event_counts"][refused] == 0 for info in infos.values())
    started = TASK_EVENTS.index("TASK_STARTED")
    assert sum(int(info["task_event_counts"][started]) for info in infos.values()) > 1
