"""One episode collected for the 3D replay as per-step arrays, sent with ``send_columns``.

One call per entity sends a whole episode. Collecting needs no rerun; only
:meth:`EpisodeCollector.send` imports it. On an episode with events (docs/uncertainty.md) a
component not yet delivered is not drawn (it appears when it is delivered), a crane that is
down has a red hook, the zones closed at a step are drawn as red boxes
(``site/closed``) and the events are in the text log.

Each crane's timeline (``multicrane.replay.timeline``) goes beside the 3D view: its activity
code at every step as a lane (``cranes/crane_k/activity``: 3 assembles, 2 holds an arrived
component, 1 lifts, 0 waits, -1 down) and a text log (``cranes/crane_k/log``) with a line as
each interval starts (``lifts c3``, ``assembles c3``, ``waits``, ``breaks down``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from multicrane.core.codes import Status
from multicrane.render.scene import (
    TIMELINE,
    crane_lane,
    crane_log,
    import_rerun,
    log_static,
    pack_colors,
)
from multicrane.replay.record import EventRow
from multicrane.replay.timeline import CODES, DOWN, Interval, Timeline, activity_codes, describe

if TYPE_CHECKING:
    from multicrane.envs.crane_env import MultiCraneEnv

# Events shown in the text log, with their level.
LOGGED_EVENTS = {
    "CLAIMED": "INFO",
    "ARRIVED": "INFO",
    "ASSEMBLED": "INFO",
    "BLOCKED": "WARN",
    "LIFT_BLOCKED": "WARN",
    "CLAIM_CONFLICT": "WARN",
    "ILLEGAL": "WARN",
    "DELIVERED": "INFO",
    "CRANE_DOWN": "WARN",
    "CRANE_UP": "INFO",
    "ZONE_CLOSED": "WARN",
    "ZONE_OPENED": "INFO",
}
HOOK_UP = 0xFFDC00FF  # yellow, as the static hook colour
HOOK_DOWN = 0xE02020FF  # red: the crane is down
CLOSED_COLOR = (230, 40, 40, 70)


class EpisodeCollector:
    """A ``StepListener`` that keeps, per step, what the replay draws.

    Pass it to ``record_episode(..., listeners=[collector])`` or ``resimulate_steps``; then
    ``send(rec)`` logs everything with ``send_columns``.
    """

    def __init__(self) -> None:
        self.env: MultiCraneEnv | None = None
        self.timeline = Timeline()

    def on_reset(self, env: MultiCraneEnv) -> None:
        self.env = env
        self.timeline.on_reset(env)
        self.steps: list[int] = []
        self.status: list[np.ndarray] = []
        self.cells: list[list[list[int]]] = []  # per step, each component's cell list
        self.held: list[list[int]] = []
        self.rewards: list[float] = []
        self.events: list[list[EventRow]] = []
        self.up: list[list[bool]] = []  # per step, each crane available (with events)
        self.closed: list[list] = []  # per step, the (lo, hi) boxes closed (with events)
        self.delivered: list[np.ndarray] = []  # per step, each component on site (with events)
        self._capture(0.0, [])

    def on_step(self, env: MultiCraneEnv, actions: list[int], reward: float, events) -> None:
        self.timeline.on_step(env, actions, reward, events)
        self._capture(reward, events)

    def _capture(self, reward: float, events: list[EventRow]) -> None:
        # Cheap on purpose: the simulator replaces a moved component's cell list (it never
        # mutates one), so keeping references is enough; boxes are computed in ``boxes``.
        sim = self.env.sim
        self.steps.append(sim.state.step_count)
        self.status.append(sim.state.status.copy())
        self.cells.append(list(sim.state.cells))
        self.held.append(list(sim.state.held))
        self.rewards.append(reward)
        site = getattr(self.env, "last_site_events", ())  # the schedule's, this step
        self.events.append(list(events) + [(e.type.name, e.crane, e.component) for e in site])
        schedule = getattr(sim, "schedule", None)
        st_cells = sim.state.cells
        if schedule is not None:
            t = sim.state.step_count
            self.up.append([bool(sim.crane_up(k)) for k in range(sim.n_cranes)])
            self.delivered.append(np.array([sim.delivered(c) for c in range(len(st_cells))]))
            self.closed.append([schedule.closures[i].box for i in schedule.closures_at(t)])

    def boxes(self, start: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Box corners ``lo, hi`` (T, C, 3) of every component from step index ``start``."""
        sim = self.env.sim
        per_step = self.cells[start:]
        T, n = len(per_step), sim.site.n_components
        lo = np.empty((T, n, 3), dtype=np.float32)
        hi = np.empty((T, n, 3), dtype=np.float32)
        last: list = [None] * n
        lo_now = np.zeros((n, 3), dtype=np.float32)
        hi_now = np.zeros((n, 3), dtype=np.float32)
        cell = sim.site.cell
        for t, cells in enumerate(per_step):
            for i, c in enumerate(cells):
                if c is not last[i]:
                    last[i] = c
                    # A component is a box of cells (a straight run, or a panel): the
                    # smallest and largest linear indices are its two corner cells.
                    lo_now[i] = cell(min(c))
                    hi_now[i] = cell(max(c))
            lo[t] = lo_now
            hi[t] = hi_now
        lo[..., 2] -= 1
        hi[..., :2] += 1
        return lo, hi

    def present(self) -> np.ndarray:
        """(T, C) bool: the component is on site (delivered) at each collected step."""
        if self.delivered:
            return np.stack(self.delivered)
        return np.ones((len(self.cells), self.env.sim.site.n_components), dtype=bool)

    # -- sending -----------------------------------------------------------------------------

    def send(self, rec, static: bool = True) -> None:
        """Log the collected episode to ``rec`` (a RecordingStream): static site (unless
        ``static=False``), then every time series with one ``send_columns`` per entity."""
        rr = import_rerun()
        env = self.env
        if env is None:
            raise RuntimeError("nothing collected: the collector never saw a reset")
        if static:
            log_static(rec, env.scenario, env.sim)
        steps = np.asarray(self.steps, dtype=np.int64)
        T, n = len(steps), env.sim.site.n_components
        time = [rr.TimeColumn(TIMELINE, sequence=steps)]
        lo, hi = self.boxes()
        status = np.stack(self.status)
        present = self.present()
        half = (hi - lo) / 2
        half[~present] = 0.0
        colors = pack_colors(status, env.sim.site.kind)
        colors[~present] = 0  # fully transparent
        rec.send_columns(
            "components",
            indexes=time,
            columns=rr.Boxes3D.columns(
                centers=((lo + hi) / 2).reshape(-1, 3),
                half_sizes=half.reshape(-1, 3),
                colors=colors.reshape(-1),
            ).partition([n] * T),
        )
        hooks, cables = crane_geometry(env, lo, hi, np.asarray(self.held))
        k = env.sim.n_cranes
        hook_columns = {"positions": hooks.reshape(-1, 3)}
        if self.up:
            hook_columns["colors"] = (
                np.where(np.asarray(self.up), HOOK_UP, HOOK_DOWN).astype(np.uint32).reshape(-1)
            )
        rec.send_columns(
            "cranes/hooks",
            indexes=time,
            columns=rr.Points3D.columns(**hook_columns).partition([k] * T),
        )
        if self.closed:
            self._send_closed(rec, rr, time)
        rec.send_columns(
            "cranes/cables",
            indexes=time,
            columns=rr.LineStrips3D.columns(strips=cables.reshape(-1, 2, 3)).partition([k] * T),
        )
        rewards = np.asarray(self.rewards)
        assembled = (status == int(Status.ASSEMBLED)).sum(axis=1)
        for name, values in (
            ("reward", rewards),
            ("return", np.cumsum(rewards)),
            ("progress", assembled / max(n, 1)),
        ):
            rec.send_columns(
                f"metrics/{name}", indexes=time, columns=rr.Scalars.columns(scalars=values)
            )
        texts, levels, at = [], [], []
        for t, events in zip(steps, self.events, strict=True):
            for etype, crane, comp in events:
                if etype in LOGGED_EVENTS:
                    texts.append(event_text(env, etype, crane, comp))
                    levels.append(LOGGED_EVENTS[etype])
                    at.append(t)
        if texts:
            rec.send_columns(
                "events",
                indexes=[rr.TimeColumn(TIMELINE, sequence=np.asarray(at, dtype=np.int64))],
                columns=rr.TextLog.columns(text=texts, level=levels),
            )
        self._send_timeline(rec, rr)

    def _send_timeline(self, rec, rr) -> None:
        """Each crane's lane (its activity code at times 0 .. steps - 1) and its text log."""
        timeline, ids = self.timeline, self.env.scenario.ids
        intervals = timeline.intervals
        codes = activity_codes(intervals, timeline.n_cranes, timeline.steps)
        time = [rr.TimeColumn(TIMELINE, sequence=np.arange(timeline.steps, dtype=np.int64))]
        for k in range(timeline.n_cranes):
            log_lane_style(rec, rr, k)
            if not timeline.steps:
                continue
            rec.send_columns(
                crane_lane(k), indexes=time, columns=rr.Scalars.columns(scalars=codes[k])
            )
            mine = [iv for iv in intervals if iv.crane == k]
            starts = np.array([iv.start for iv in mine], dtype=np.int64)
            rec.send_columns(
                crane_log(k),
                indexes=[rr.TimeColumn(TIMELINE, sequence=starts)],
                columns=rr.TextLog.columns(
                    text=[describe(iv, ids) for iv in mine], level=[_level(iv) for iv in mine]
                ),
            )

    def _send_closed(self, rec, rr, time) -> None:
        """The closed zones of every step as boxes (none at a step: an empty batch)."""
        centers, halves = [], []
        for boxes in self.closed:
            for (x0, y0, z0), (x1, y1, z1) in boxes:
                lo = np.array([x0, y0, z0 - 1], dtype=np.float32)
                hi = np.array([x1 + 1, y1 + 1, z1], dtype=np.float32)
                centers.append((lo + hi) / 2)
                halves.append((hi - lo) / 2)
        empty = np.zeros((0, 3), dtype=np.float32)
        rec.send_columns(
            "site/closed",
            indexes=time,
            columns=rr.Boxes3D.columns(
                centers=np.array(centers, dtype=np.float32) if centers else empty,
                half_sizes=np.array(halves, dtype=np.float32) if halves else empty,
                colors=[CLOSED_COLOR] * len(centers),
            ).partition([len(b) for b in self.closed]),
        )


# The lanes' legend: what each activity code means.
LANE_LEGEND = ", ".join(f"{c} {w}" for w, c in sorted(CODES.items(), key=lambda wc: -wc[1]))


def log_lane_style(rec, rr, crane: int) -> None:
    """A crane's lane style (static): its legend names the activity codes."""
    rec.log(crane_lane(crane), rr.SeriesLines(names=LANE_LEGEND), static=True)


def _level(interval: Interval) -> str:
    return "WARN" if interval.what == DOWN else "INFO"


def log_timeline(rec, timeline: Timeline, ids, drawn: int) -> None:
    """The live view: each crane's lane and log lines from time ``drawn`` on, step by step."""
    rr = import_rerun()
    for iv in timeline.since(drawn):
        for s in range(max(iv.start, drawn), iv.end):
            rec.set_time(TIMELINE, sequence=s)
            rec.log(crane_lane(iv.crane), rr.Scalars(CODES[iv.what]))
        if iv.start >= drawn:
            rec.set_time(TIMELINE, sequence=iv.start)
            rec.log(crane_log(iv.crane), rr.TextLog(describe(iv, ids), level=_level(iv)))


def home_positions(env: MultiCraneEnv) -> np.ndarray:
    """Where the hooks wait before their first claim: spread along the low-y edge."""
    X, Y, H = env.scenario.size
    k = env.sim.n_cranes
    return np.array([[(i + 0.5) * X / k, -1.0, H + 1.0] for i in range(k)], dtype=np.float32)


def crane_geometry(
    env: MultiCraneEnv,
    lo: np.ndarray,
    hi: np.ndarray,
    held: np.ndarray,
    home: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Hook positions (T, k, 3) above held components (an idle crane stays where it last
    was; before its first claim it waits at ``home``, default ``home_positions``) and
    cables (T, k, 2, 3)."""
    T, k = held.shape
    hook_z = env.scenario.size[2] + 1.0
    if home is None:
        home = home_positions(env)
    holding = held >= 0
    rows = np.arange(T)[:, None]
    comp = np.where(holding, held, 0)
    centre = (lo[rows, comp] + hi[rows, comp]) / 2  # (T, k, 3)
    # Forward-fill each crane's position from the last step it held something.
    src = np.maximum.accumulate(np.where(holding, rows, -1), axis=0)  # (T, k)
    cranes = np.arange(k)[None, :]
    hooks = centre[np.maximum(src, 0), cranes]
    hooks[..., 2] = hook_z
    hooks[src < 0] = np.broadcast_to(home, (T, k, 3))[src < 0]
    cables = np.empty((T, k, 2, 3), dtype=np.float32)
    cables[:, :, 0] = hooks
    cables[:, :, 1] = hooks
    top = hi[rows, comp, 2]
    cables[:, :, 1, 2] = np.where(holding, top, hook_z)
    return hooks.astype(np.float32), cables


def event_text(env: MultiCraneEnv, etype: str, crane: int, comp: int) -> str:
    if etype in ("ZONE_CLOSED", "ZONE_OPENED"):
        return "a zone " + ("closes" if etype == "ZONE_CLOSED" else "opens again")
    if etype in ("CRANE_DOWN", "CRANE_UP"):
        return f"crane_{crane} " + ("breaks down" if etype == "CRANE_DOWN" else "is back")
    what = env.scenario.components[comp].id if comp >= 0 else "-"
    if etype == "DELIVERED":
        return f"{what} is delivered"
    verbs = {
        "CLAIMED": "claims",
        "ARRIVED": "brings to its target",
        "ASSEMBLED": "assembles",
        "BLOCKED": "is blocked moving",
        "LIFT_BLOCKED": "cannot lift",
        "CLAIM_CONFLICT": "lost the claim of",
        "ILLEGAL": "sent an illegal action for",
    }
    return f"crane_{crane} {verbs.get(etype, etype.lower())} {what}"
