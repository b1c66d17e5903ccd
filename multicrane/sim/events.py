"""Site events: late deliveries, crane breakdowns and closed zones, drawn once per episode.

``EventSpec`` says what may happen (a frozen dataclass: scenario data, an environment option
or a ``preset``); ``draw_schedule`` turns it into an ``EventSchedule`` with the episode's
generator at reset: when each component arrives, when each crane is down, which boxes are
closed when. The simulator (``multicrane.sim.simulator``) then applies the schedule; nothing of it
is drawn later. Times are simulator step counts; intervals are half-open ``[start, end)``;
the events of time ``t`` apply as the state reaches ``t`` (at reset for ``t = 0``, at the end
of the step that makes ``step_count == t``), so they hold before the actions chosen at ``t``.
See ``docs/uncertainty.md``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

if TYPE_CHECKING:
    from multicrane.sim.site import Site

LEVELS = ("none", "low", "high")

Cell = tuple[int, int, int]
BoxXYZ = tuple[Cell, Cell]  # (lo, hi) corners, inclusive, site coordinates (z from 1)


@dataclass(frozen=True)
class FixedClosure:
    """A box of the site closed during ``[start, end)`` (scenario data)."""

    box: BoxXYZ
    start: int
    end: int


@dataclass(frozen=True)
class EventSpec:
    """What may happen in an episode. The default (every field at rest) draws no event.

    **Deliveries.** ``arrivals``: per component (scenario order) the step it is due on site
    (empty: all at 0); each component that is not pre-built is then late with probability
    ``late_fraction``, by a number of steps drawn uniformly from ``delay`` (inclusive).
    **Breakdowns.** Each crane that is up breaks down with probability ``breakdown_rate`` per
    step, for a number of steps drawn uniformly from ``breakdown_duration``.
    **Closures.** ``closures``: fixed boxes and intervals; and at random, a new box closes with
    probability ``closure_rate`` per step (one at a time), its plan footprint ``closure_size``
    cells on a side (drawn uniformly, at a uniform place on the site, every height), for a
    number of steps drawn uniformly from ``closure_duration``.
    """

    arrivals: tuple[int, ...] = ()
    late_fraction: float = 0.0
    delay: tuple[int, int] = (0, 0)
    breakdown_rate: float = 0.0
    breakdown_duration: tuple[int, int] = (1, 1)
    closures: tuple[FixedClosure, ...] = ()
    closure_rate: float = 0.0
    closure_size: tuple[int, int] = (1, 1)
    closure_duration: tuple[int, int] = (1, 1)

    def __post_init__(self) -> None:
        for name in ("late_fraction", "breakdown_rate", "closure_rate"):
            v = getattr(self, name)
            if not 0.0 <= v <= 1.0:
                raise ValueError(f"EventSpec.{name} must lie in [0, 1], got {v!r}")
        for name, low in (("delay", 0), ("breakdown_duration", 1), ("closure_duration", 1),
                          ("closure_size", 1)):  # fmt: skip
            lo, hi = getattr(self, name)
            if not low <= lo <= hi:
                raise ValueError(f"EventSpec.{name} must be (lo, hi) with {low} <= lo <= hi, "
                                 f"got {(lo, hi)!r}")  # fmt: skip
        if any(a < 0 for a in self.arrivals):
            raise ValueError(f"EventSpec.arrivals must be >= 0, got {self.arrivals!r}")
        for c in self.closures:
            if not 0 <= c.start < c.end:
                raise ValueError(f"closure interval must have 0 <= start < end, got {c!r}")


class Outage(NamedTuple):
    """Crane ``crane`` is down during ``[start, end)``."""

    crane: int
    start: int
    end: int


class Closure(NamedTuple):
    """The ``box`` (its padded linear ``cells``) is closed during ``[start, end)``."""

    cells: tuple[int, ...]
    box: BoxXYZ
    start: int
    end: int


@dataclass
class EventSchedule:
    """One episode's events, fixed at reset (see the module doc for the time convention)."""

    arrival: np.ndarray  # (C,) int64: step a component may appear in the yard (0: from the start)
    outages: list[Outage] = field(default_factory=list)
    closures: list[Closure] = field(default_factory=list)

    def down_at(self, n_cranes: int, t: int) -> list[bool]:
        """Per crane: down at time ``t``."""
        down = [False] * n_cranes
        for o in self.outages:
            if o.start <= t < o.end and o.crane < n_cranes:
                down[o.crane] = True
        return down

    def closures_at(self, t: int) -> list[int]:
        """Indices of the closures in force at time ``t``."""
        return [i for i, c in enumerate(self.closures) if c.start <= t < c.end]

    def closed_cells(self, size: int, t: int) -> np.ndarray:
        """(size,) bool: the padded cells closed at time ``t``."""
        closed = np.zeros(size, dtype=bool)
        for i in self.closures_at(t):
            closed[list(self.closures[i].cells)] = True
        return closed

    def to_json(self) -> dict:
        """Plain JSON values (records); ``from_json`` with the same site gives it back."""
        return {
            "arrival": [int(a) for a in self.arrival],
            "outages": [[int(v) for v in o] for o in self.outages],
            "closures": [[[list(c.box[0]), list(c.box[1])], c.start, c.end] for c in self.closures],
        }

    @classmethod
    def from_json(cls, data: dict, site: Site) -> EventSchedule:
        arrival = np.array(data["arrival"], dtype=np.int64)
        if arrival.shape != (site.n_components,) or (arrival < 0).any():
            raise ValueError(f"events: arrival must be {site.n_components} steps >= 0")
        outages = [Outage(*(int(v) for v in o)) for o in data["outages"]]
        closures = [
            closure(site, (tuple(lo), tuple(hi)), int(s), int(e))
            for (lo, hi), s, e in data["closures"]
        ]
        return cls(arrival, outages, closures)

    def equals(self, other: EventSchedule) -> bool:
        return (
            np.array_equal(self.arrival, other.arrival)
            and self.outages == other.outages
            and self.closures == other.closures
        )


def closure(site: Site, box: BoxXYZ, start: int, end: int) -> Closure:
    """A closure of ``box`` (clipped to the site) during ``[start, end)``."""
    X, Y, H = site.scenario.size
    (x0, y0, z0), (x1, y1, z1) = box
    x0, y0, z0 = max(x0, 0), max(y0, 0), max(z0, 1)
    x1, y1, z1 = min(x1, X - 1), min(y1, Y - 1), min(z1, H)
    cells = tuple(
        site.lin(x, y, z)
        for x in range(x0, x1 + 1)
        for y in range(y0, y1 + 1)
        for z in range(z0, z1 + 1)
    )
    return Closure(cells, ((x0, y0, z0), (x1, y1, z1)), int(start), int(end))


def _intervals(rng: np.random.Generator, rate: float, lo: int, hi: int, horizon: int):
    """Intervals of a process that starts with probability ``rate`` per step while at rest
    and lasts ``lo..hi`` steps: ``(start, end)`` pairs with ``1 <= start < horizon``."""
    out: list[tuple[int, int]] = []
    if rate <= 0.0:
        return out
    t = 0
    while True:
        t += int(rng.geometric(rate))
        if t >= horizon:
            return out
        end = t + int(rng.integers(lo, hi + 1))
        out.append((t, end))
        t = end - 1


def draw_schedule(
    spec: EventSpec, site: Site, prebuilt: np.ndarray, n_cranes: int, horizon: int,
    rng: np.random.Generator,
) -> EventSchedule:  # fmt: skip
    """The episode's schedule, drawn from ``rng`` (deliveries, then each crane's breakdowns,
    then the random closures): the same generator state gives the same schedule."""
    n = site.n_components
    if spec.arrivals and len(spec.arrivals) != n:
        raise ValueError(
            f"EventSpec.arrivals has {len(spec.arrivals)} entries for {n} components"
        )
    arrival = np.array(spec.arrivals or [0] * n, dtype=np.int64)
    late = rng.random(n) < spec.late_fraction
    delay = rng.integers(spec.delay[0], spec.delay[1] + 1, size=n)
    arrival = np.where(late, arrival + delay, arrival)
    arrival[np.asarray(prebuilt, dtype=bool)] = 0
    outages = [
        Outage(k, s, e)
        for k in range(n_cranes)
        for s, e in _intervals(rng, spec.breakdown_rate, *spec.breakdown_duration, horizon)
    ]
    closures = [closure(site, c.box, c.start, c.end) for c in spec.closures]
    X, Y, H = site.scenario.size
    for s, e in _intervals(rng, spec.closure_rate, *spec.closure_duration, horizon):
        sx, sy = (int(v) for v in rng.integers(spec.closure_size[0], spec.closure_size[1] + 1, 2))
        sx, sy = min(sx, X), min(sy, Y)
        x0 = int(rng.integers(0, X - sx + 1))
        y0 = int(rng.integers(0, Y - sy + 1))
        closures.append(closure(site, ((x0, y0, 1), (x0 + sx - 1, y0 + sy - 1, H)), s, e))
    return EventSchedule(arrival, outages, closures)


def preset(level: str, scenario) -> EventSpec:
    """The disruption levels of the benchmark, scaled by ``D = X + Y + H`` of the site (about
    one trip across it). ``none``: no event. ``low``: a quarter of the components late by
    1..2D steps; per crane a breakdown every 20D steps on average, lasting D/2..D; a random
    closure every 20D steps, 1..max(1, min(X, Y) // 4) cells on a side, lasting D/2..D.
    ``high``: half the components late by 1..4D; breakdowns and closures every 5D steps on
    average, lasting D..2D; closures up to max(1, min(X, Y) // 3) on a side."""
    if level not in LEVELS:
        raise ValueError(f"events level must be one of {LEVELS}, got {level!r}")
    if level == "none":
        return EventSpec()
    X, Y, H = scenario.size
    D = X + Y + H
    if level == "low":
        half = max(1, D // 2)
        side = max(1, min(X, Y) // 4)
        return EventSpec(
            late_fraction=0.25, delay=(1, 2 * D),
            breakdown_rate=1 / (20 * D), breakdown_duration=(half, D),
            closure_rate=1 / (20 * D), closure_size=(1, side), closure_duration=(half, D),
        )  # fmt: skip
    side = max(1, min(X, Y) // 3)
    return EventSpec(
        late_fraction=0.5, delay=(1, 4 * D),
        breakdown_rate=1 / (5 * D), breakdown_duration=(D, 2 * D),
        closure_rate=1 / (5 * D), closure_size=(1, side), closure_duration=(D, 2 * D),
    )  # fmt: skip


def resolve(events, scenario) -> EventSpec | None:
    """The environment option: ``None`` (the scenario's ``[events]`` table if any, else no
    events), a level name of ``LEVELS``, or an ``EventSpec``."""
    if events is None:
        return getattr(scenario, "events", None)
    if isinstance(events, EventSpec):
        return events
    if isinstance(events, str):
        return preset(events, scenario)
    raise ValueError(f"events must be None, one of {LEVELS} or an EventSpec, got {events!r}")
