"""Checks at the environments' boundary: integer actions, options, calls before reset, masks.

Both environments (``crane_env`` and ``paper_env``) and the episode records use these, so
one rule holds everywhere: an action is a Python or numpy integer (not a bool, a float or a
string; ``2.7`` is never silently taken as ``2``), and a method that needs an episode says
"call reset() first" instead of failing somewhere inside.
"""

from __future__ import annotations

import operator
from typing import Any

import numpy as np

from multicrane.scenario.limits import MAX_CRANES


class ActionTypeError(TypeError, ValueError):
    """An action that is not an integer (a ``TypeError`` and, for old callers, a
    ``ValueError``)."""


def as_integer(value: Any, what: str) -> int:
    """``value`` as an int when it is a Python or numpy integer (or a 0-d integer array);
    else :class:`ActionTypeError` naming ``what`` and the value. Bools are refused."""
    if type(value) is int:  # the common case first (a bool's type is bool)
        return value
    if isinstance(value, bool | np.bool_):
        raise ActionTypeError(f"{what} must be an integer, got the bool {value!r}")
    try:
        return operator.index(value)
    except TypeError:
        raise ActionTypeError(
            f"{what} must be an integer, got {value!r} ({type(value).__name__})"
        ) from None


def action_index(value: Any, agent: str, n_actions: int) -> int:
    """A crane's action as an int in ``0..n_actions - 1``; else an error naming the agent."""
    a = value if type(value) is int else as_integer(value, f"step(): the action of {agent}")
    if not 0 <= a < n_actions:
        raise ValueError(f"step(): {agent} sent action {a}, outside 0..{n_actions - 1}")
    return a


def crane_count(n_cranes: Any) -> int | None:
    """The environment's ``n_cranes`` option: None (the scenario's) or an integer in
    1..``MAX_CRANES``; else TypeError/ValueError naming the value."""
    if n_cranes is None:
        return None
    n = as_integer(n_cranes, "n_cranes")
    if not 1 <= n <= MAX_CRANES:
        raise ValueError(f"n_cranes must be 1..{MAX_CRANES} (MAX_CRANES), got {n}")
    return n


def require_reset(started: bool, method: str) -> None:
    """RuntimeError for a method that needs an episode, before the first ``reset()``."""
    if not started:
        raise RuntimeError(f"{method}() called before reset(): call reset() first")


def handed_out(masks: list[np.ndarray]) -> list[np.ndarray]:
    """Copies of the environment's masks for the caller: changing them cannot change what
    the environment (strict mode included) takes as legal."""
    return [m.copy() for m in masks]


def one_of(option: str, value: Any, allowed: tuple) -> None:
    """ValueError naming the option and its allowed values when ``value`` is not one."""
    if value not in allowed:
        raise ValueError(f"{option} must be one of {allowed}, got {value!r}")
