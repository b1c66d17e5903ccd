"""The decision modes of ``MultiCraneEnv``: their one interface and the one table of them by name.

A decision mode is what a crane's action means: ``"motion"`` (``MotionMode``, one move per
step, the default) or ``"task"`` (``TaskMode``, which task next; ``docs/task-mode.md``).
``MultiCraneEnv(decisions=name)`` looks the name up once in ``DECISION_MODES``
(``decision_mode``), builds the mode with the simulator and its ``ModeSettings``, and
delegates to it the action space, the reset, the step, the observations and masks, the
task facts of the infos and what a planner may ask; ``env.decisions`` keeps the name, and
``env.mode`` the mode. Code that must know the level asks the mode (``mode.task_level``, or
``task_level(env)`` for any environment), never compares names.

A new mode is a class with the members of ``DecisionMode`` (subclassing ``MotionMode`` gives
the motion defaults) and a row in ``DECISION_MODES``.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from multicrane.envs.infos import TaskStepFacts
from multicrane.envs.motion_mode import ModeSettings, ModeStep, MotionMode
from multicrane.envs.task_mode import TaskMode

DEFAULT_DECISIONS = "motion"


class DecisionMode(Protocol):
    """What ``MultiCraneEnv`` asks of a decision mode; built as ``Mode(sim, settings)``."""

    task_level: bool  # actions choose tasks: the task-level planners drive it
    n_actions: int  # the size of each crane's Discrete action space
    wait_action: int  # the action that waits (always allowed by the masks)
    observer: object  # ``layout`` (the observation's) and ``reset(step_limit)``

    def reset(self, rng: np.random.Generator) -> TaskStepFacts | None:
        """Start an episode on the reset simulator; the task facts of the reset's infos."""

    def step(self, joint: list[int]) -> ModeStep:
        """Play one env step of the joint action (one simulated step or more)."""

    def observe(self) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """Every crane's observation vector and action mask, in crane order."""

    def describe(self, action: int) -> str:
        """The readable name of an action (for the strict mode's errors)."""

    def feasible(self, crane: int, task: int) -> bool:
        """Would ``task`` start for ``crane`` now (task level; others raise)."""

    def task_book(self):
        """The episode's ``multicrane.tasks.book.TaskBook`` (task level; others raise)."""

    def carrier_stats(self) -> dict:
        """The carrier's counters (task level; others raise)."""


DECISION_MODES: dict[str, type[DecisionMode]] = {"motion": MotionMode, "task": TaskMode}


def decision_mode(name: str) -> type[DecisionMode]:
    """The mode class named ``name`` in ``DECISION_MODES`` (``ValueError`` naming the valid
    names if none)."""
    try:
        return DECISION_MODES[name]
    except (KeyError, TypeError):
        raise ValueError(
            f"decisions must be one of {tuple(DECISION_MODES)}, got {name!r}"
        ) from None


def task_level(env) -> bool:
    """Whether ``env`` (or the environment a wrapper's ``unwrapped`` gives) decides at a task
    level; False for an environment without a decision mode (the paper env, a stand-in)."""
    mode = getattr(getattr(env, "unwrapped", env), "mode", None)
    return bool(getattr(mode, "task_level", False))


__all__ = [
    "DECISION_MODES",
    "DEFAULT_DECISIONS",
    "DecisionMode",
    "ModeSettings",
    "ModeStep",
    "MotionMode",
    "TaskMode",
    "decision_mode",
    "task_level",
]
