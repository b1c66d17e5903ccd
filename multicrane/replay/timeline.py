"""Per-crane timelines of an episode: who lifts, holds, assembles, waits or is down, and when.

    from multicrane.replay.timeline import Timeline, timeline_of
    intervals = timeline_of(record)               # an EpisodeRecord, re-simulated
    timeline = Timeline()                         # or live: a StepListener of record_episode
    record_episode(env, policy, seed, listeners=[timeline]); timeline.intervals

Time is counted in steps: step ``t`` of the episode takes the site from time ``t - 1`` to time
``t``, so an :class:`Interval` ``[start, end)`` holds the steps ``start + 1 .. end`` and time
``0`` is the reset. The intervals of each crane cover ``[0, steps)`` exactly once, and each is
one of (``what``):

- ``lift``: from the claim (or, in automatic mode, the assignment) to the time the component
  arrives on its target (``end`` is the step of ``ARRIVED``);
- ``hold``: holding an arrived component, its assembly not started;
- ``assemble``: from the assemble action to ``ASSEMBLED`` (``assembly_steps`` steps unless a
  breakdown pauses it; the automatic mode assembles on arrival, in no time);
- ``wait``: nothing held;
- ``down``: broken down (a site event: ``sim.crane_up(k)`` is false at time ``start .. end-1``);
  ``component`` is what the crane holds meanwhile (-1: nothing).

``component`` is the component's index in scenario order (-1 for ``wait``). The intervals are
read from each physical step's crane events and the episode's event schedule, so they are the
same for a re-simulated record and a live episode, in the motion and task modes (a task-mode
step advances several physical steps: the mode's ``trace_events`` has them). The rerun replay
(``multicrane.replay.viewer_episode``) draws them as a lane and a text log per crane; a Gantt
chart (``multicrane.reports.gantt``) draws them as bars.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from multicrane.replay.record import EventRow, resimulate_steps
from multicrane.sim.site import NOBODY

if TYPE_CHECKING:
    from multicrane.envs.crane_env import MultiCraneEnv
    from multicrane.replay.record import EpisodeRecord

LIFT, HOLD, ASSEMBLE, WAIT, DOWN = "lift", "hold", "assemble", "wait", "down"
# Each activity's code for a plotted lane: busy above idle, down below it.
CODES = {DOWN: -1, WAIT: 0, LIFT: 1, HOLD: 2, ASSEMBLE: 3}
# What a crane's text log says as an interval starts.
VERBS = {
    LIFT: "lifts",
    HOLD: "holds",
    ASSEMBLE: "assembles",
    WAIT: "waits",
    DOWN: "breaks down",
}
# The crane events that change what a crane is doing, and its phase after each.
_PHASE_AFTER = {
    "CLAIMED": LIFT,
    "ASSIGNED": LIFT,
    "ARRIVED": HOLD,
    "ASSEMBLY_STARTED": ASSEMBLE,
    "ASSEMBLED": WAIT,
}


@dataclass(frozen=True)
class Interval:
    """Crane ``crane`` does ``what`` (to ``component``, -1: none) from time ``start`` to
    ``end`` (steps ``start + 1 .. end``)."""

    crane: int
    start: int
    end: int
    what: str
    component: int = NOBODY

    @property
    def steps(self) -> int:
        return self.end - self.start


class Timeline:
    """A ``StepListener`` (``multicrane.replay.record``) building each crane's intervals.

    ``intervals`` is valid at any time: those of the steps seen so far (the last interval of a
    crane ends at the current time ``steps``).
    """

    def __init__(self) -> None:
        self.n_cranes = 0
        self.steps = 0
        self._runs: list[list[list]] = []  # per crane: [start, end, what, component] rows

    def on_reset(self, env: MultiCraneEnv) -> None:
        sim = env.unwrapped.sim
        self.n_cranes = sim.n_cranes
        self.steps = 0
        self._runs = [[] for _ in range(self.n_cranes)]
        # Automatic mode assigns at reset: those cranes start with a lift.
        self._held = [int(c) for c in sim.state.held]
        self._phase = [WAIT if c == NOBODY else LIFT for c in self._held]
        self._schedule = sim.schedule  # None: no site events
        self._mode = env.unwrapped.mode
        self._seen_trace = 0

    def on_step(
        self, env: MultiCraneEnv, actions: list[int], reward: float, events: list[EventRow]
    ) -> None:
        if not self._mode.task_level:
            self._physical_step(events)
            return
        trace = self._mode.trace_events  # a task-mode step: every physical step it advanced
        for step in trace[self._seen_trace :]:
            self._physical_step([(e.type.name, int(e.crane), int(e.component)) for e in step])
        self._seen_trace = len(trace)

    def _physical_step(self, events: Sequence[EventRow]) -> None:
        """Step ``self.steps + 1``: each crane's activity in it, then its phase after it."""
        t = self.steps
        n = self.n_cranes
        down = self._schedule.down_at(n, t) if self._schedule is not None else [False] * n
        started = [False] * n
        claimed = [NOBODY] * n
        for etype, crane, comp in events:
            if etype == "ASSEMBLY_STARTED":
                started[crane] = True
            elif etype == "CLAIMED":
                claimed[crane] = comp
        for k in range(n):
            phase, comp = self._phase[k], self._held[k]
            if down[k]:
                what = DOWN
            elif phase == HOLD and started[k]:
                what = ASSEMBLE
            elif phase == WAIT and claimed[k] != NOBODY:
                what, comp = LIFT, claimed[k]
            else:
                what = phase
            self._extend(k, t, what, comp if what != WAIT else NOBODY)
        for etype, crane, comp in events:
            phase = _PHASE_AFTER.get(etype)
            if phase is not None:
                self._phase[crane] = phase
                self._held[crane] = NOBODY if phase == WAIT else comp
        self.steps = t + 1

    def _extend(self, crane: int, t: int, what: str, comp: int) -> None:
        runs = self._runs[crane]
        if runs and runs[-1][2] == what and runs[-1][3] == comp:
            runs[-1][1] = t + 1
        else:
            runs.append([t, t + 1, what, comp])

    @property
    def intervals(self) -> list[Interval]:
        """Every crane's intervals, by crane then time."""
        return [Interval(k, *run) for k, runs in enumerate(self._runs) for run in runs]

    def since(self, t: int) -> list[Interval]:
        """The intervals that reach past time ``t`` (by crane, then time): what a live view
        has not drawn yet when it drew up to ``t``."""
        out = []
        for k, runs in enumerate(self._runs):
            first = len(runs)
            while first and runs[first - 1][1] > t:
                first -= 1
            out.extend(Interval(k, *run) for run in runs[first:])
        return out


def timeline_of(record: EpisodeRecord) -> list[Interval]:
    """The intervals of a record's episode, re-simulated (and checked) step by step."""
    timeline = Timeline()
    for _ in resimulate_steps(record, listeners=[timeline]):
        pass
    return timeline.intervals


def activity_codes(intervals: Sequence[Interval], n_cranes: int, steps: int) -> np.ndarray:
    """(n_cranes, steps) int8: each crane's ``CODES`` value during each step (time ``s`` to
    ``s + 1``); steps no interval covers are ``wait``."""
    codes = np.full((n_cranes, steps), CODES[WAIT], dtype=np.int8)
    for iv in intervals:
        codes[iv.crane, iv.start : iv.end] = CODES[iv.what]
    return codes


def describe(interval: Interval, ids: Sequence[str]) -> str:
    """A crane's text log line for an interval: ``lifts C3``, ``waits``, ``breaks down``."""
    verb = VERBS[interval.what]
    if interval.component == NOBODY:
        return verb
    what = ids[interval.component]
    return f"{verb} {what}" if interval.what != DOWN else f"{verb} holding {what}"


__all__ = [
    "ASSEMBLE",
    "CODES",
    "DOWN",
    "HOLD",
    "Interval",
    "LIFT",
    "Timeline",
    "VERBS",
    "WAIT",
    "activity_codes",
    "describe",
    "timeline_of",
]
