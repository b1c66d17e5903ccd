"""The environments' infos: numeric by default, the readable events and the mask on request.

Every library that batches infos (TorchRL, Tianshou, RLlib, SuperSuit) needs the same keys
with numbers of a fixed shape at every step, reset included. So by default ``infos[agent]``
holds only numbers:

- ``event_counts``: ``int32`` array, one count per ``EventType`` (in its order: index ``i``
  counts ``EventType(i)``) of this crane's events in the step;
- ``reward_term``: this crane's share of the team reward (the shares add up to it);
- with site events (``events=``) only: ``site_event_counts`` (``int32``, one count per
  ``SiteEventType``) of the site's events in the step (the same for every crane);
- task level only: ``task_event_counts`` (``int32``, one count per ``TASK_EVENTS`` name),
  ``elapsed`` (simulated steps of the step) and ``crane_steps`` (busy crane x step pairs).

``info_events=True`` adds the readable ``events`` (``Event`` tuples) and, at the task level,
``task_events``; ``info_mask=True`` adds ``action_mask`` (a copy of the observation's). The
environments always keep the last step's events as ``env.last_events`` for code that needs
them whatever the options (rollouts, records, viewers).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from multicrane.core.codes import Event, EventType, SiteEvent, SiteEventType

N_EVENT_TYPES = len(EventType)
TASK_EVENTS = ("TASK_STARTED", "TASK_HELD", "TASK_DROPPED", "TASK_REFUSED", "TASK_DONE")
_TASK_INDEX = {name: i for i, name in enumerate(TASK_EVENTS)}


def event_counts(events: Iterable[Event]) -> np.ndarray:
    """How many events of each ``EventType`` (``int32``, ``len(EventType)`` entries)."""
    out = np.zeros(N_EVENT_TYPES, dtype=np.int32)
    for e in events:
        out[int(e.type)] += 1
    return out


def site_event_counts(events: Iterable[SiteEvent]) -> np.ndarray:
    """How many site events of each ``SiteEventType`` (``int32``)."""
    out = np.zeros(len(SiteEventType), dtype=np.int32)
    for e in events:
        out[int(e.type)] += 1
    return out


def task_event_counts(task_events: Iterable[tuple[str, int, int]]) -> np.ndarray:
    """How many task events of each ``TASK_EVENTS`` name (``int32``)."""
    out = np.zeros(len(TASK_EVENTS), dtype=np.int32)
    for name, _, _ in task_events:
        out[_TASK_INDEX[name]] += 1
    return out


class TaskStepFacts:
    """What a task-level step adds to the infos: task events per crane, elapsed steps and
    busy crane-steps."""

    def __init__(self, per_crane: Sequence[tuple], elapsed: int, crane_steps: int):
        self.per_crane = per_crane
        self.elapsed = elapsed
        self.crane_steps = crane_steps


def crane_infos(
    agents: Sequence[str],
    per_crane: Sequence[tuple[Event, ...]],
    terms: Sequence[float],
    masks: Sequence[np.ndarray],
    *,
    events: bool,
    mask: bool,
    task: TaskStepFacts | None = None,
    site: Sequence[SiteEvent] | None = None,
) -> dict[str, dict[str, Any]]:
    """``infos`` of one step (or reset) of the multi-agent environment (see the module doc)."""
    infos: dict[str, dict[str, Any]] = {}
    site_counts = None if site is None else site_event_counts(site)
    for i, a in enumerate(agents):
        info: dict[str, Any] = {
            "event_counts": event_counts(per_crane[i]),
            "reward_term": float(terms[i]),
        }
        if site_counts is not None:
            info["site_event_counts"] = site_counts.copy()
        if task is not None:
            info["task_event_counts"] = task_event_counts(task.per_crane[i])
            info["elapsed"] = task.elapsed
            info["crane_steps"] = task.crane_steps
        if events:
            info["events"] = tuple(per_crane[i])
            if task is not None:
                info["task_events"] = tuple(task.per_crane[i])
        if mask:
            info["action_mask"] = masks[i]
        infos[a] = info
    return infos
