"""3D replays with rerun: episodes to .rrd files, to a viewer, or live as they run.

    from multicrane.replay.viewer import record_to_rrd, LiveViewer
    record_to_rrd(record, "episode.rrd")          # an EpisodeRecord, re-simulated, to a file

This module is the entry point (``pip install "multicrane[replay]"``); the static site and the
viewer's panels are drawn by ``multicrane.render.scene``, whole episodes are collected and
sent by ``multicrane.replay.viewer_episode``.

Entities (one timeline, ``step``; step 0 is the state after reset):

- ``site/ground``, ``site/construction_area``, ``site/foundations``, ``site/obstacles``,
  ``site/targets`` (wireframes): static.
- ``components``: one box per component (scenario order), coloured by state as in the
  paper: initial orange, in transit blue, arrived green, assembled pink.
- ``cranes/hooks`` (a point labelled ``crane_i`` above what each crane holds; an idle crane
  stays where it last was) and ``cranes/cables`` (hook to component).
- ``metrics/reward``, ``metrics/return``, ``metrics/progress`` (assembled fraction).
- ``events``: a text log of claims, blocked moves, arrivals and assemblies.
- ``cranes/crane_k/activity`` and ``cranes/crane_k/log``: each crane's timeline (lifts,
  assemblies, waits, breakdowns; ``multicrane.replay.timeline``), a lane under the 3D view
  and a text log.

A cell ``(x, y, z)`` is drawn as the unit cube ``[x, x+1] x [y, y+1] x [z-1, z]``, so the
ground is the plane ``z = 0``. Whole episodes go out with ``send_columns`` (one call per
entity); the live viewer logs step by step.

rerun is imported lazily: ``import multicrane`` never needs it.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from multicrane.core.codes import Status
from multicrane.render.scene import (
    APPLICATION_ID,
    PANEL_STATE_COLORS,
    STATE_COLORS,
    TIMELINE,
    blueprint,
    import_rerun,
    log_static,
    pack_colors,
)
from multicrane.render.viewers import connect_viewer, spawn_viewer
from multicrane.replay.record import EpisodeRecord, record_episode, resimulate_steps
from multicrane.replay.viewer_episode import (
    LOGGED_EVENTS,
    EpisodeCollector,
    crane_geometry,
    event_text,
    home_positions,
    log_lane_style,
    log_timeline,
)

if TYPE_CHECKING:
    from multicrane.core.schema import Scenario
    from multicrane.envs.crane_env import MultiCraneEnv


def new_recording(name: str = "", recording_id: str | None = None):
    """A RecordingStream for one episode, with the automatic wall-clock timeline off."""
    rr = import_rerun()
    rec = rr.RecordingStream(APPLICATION_ID, recording_id=recording_id)
    rec.set_log_time_enabled(False)
    rec.set_log_tick_enabled(False)
    if name:
        rec.send_recording_name(name)
    return rec


def _name(record: EpisodeRecord) -> str:
    policy = f" {record.policy}" if record.policy else ""
    return f"{record.scenario} {record.n_cranes} cranes{policy} seed {record.seed}"


def record_to_rrd(record: EpisodeRecord, path: str | Path, play_state: str | None = None) -> Path:
    """Re-simulate a record (checked) and save it as an .rrd file with its blueprint."""
    collector = EpisodeCollector()
    for _ in resimulate_steps(record, listeners=[collector]):
        pass
    return save_collected(
        collector, path, name=_name(record), recording_id=_rid(record), play_state=play_state
    )


def _rid(record: EpisodeRecord) -> str:
    return f"{record.scenario}-{record.scenario_sha256[:12]}-c{record.n_cranes}-s{record.seed}"


def save_collected(
    collector: EpisodeCollector,
    path: str | Path,
    name: str = "",
    recording_id: str | None = None,
    play_state: str | None = None,
) -> Path:
    """Write a collected episode to an .rrd file."""
    path = Path(path)
    rec = new_recording(name, recording_id)
    env = collector.env
    rec.save(path, default_blueprint=blueprint(env.scenario, play_state, env.sim.n_cranes))
    collector.send(rec)
    rec.flush()
    rec.disconnect()
    return path


def send_record(record: EpisodeRecord, rec) -> None:
    """Re-simulate a record and send it to an already connected stream."""
    collector = EpisodeCollector()
    for _ in resimulate_steps(record, listeners=[collector]):
        pass
    rec.send_blueprint(blueprint(collector.env.scenario, n_cranes=collector.env.sim.n_cranes))
    collector.send(rec)


def connect(
    rec,
    url: str | None = None,
    spawn: bool = False,
    scenario: Scenario | None = None,
    play_state: str | None = None,
):
    """Connect a stream to a viewer: ``spawn`` one (on PATH or beside the running Python), or
    the running one at ``url`` (default: the local one); ``NoViewer`` (one line) when there is
    none to reach (``multicrane.render.viewers``)."""
    bp = blueprint(scenario, play_state) if scenario is not None else None
    if spawn:
        spawn_viewer(rec, bp)
    else:
        connect_viewer(rec, url, bp)
    return rec


class LiveViewer:
    """A ``StepListener`` that logs each step to a stream as the environment runs."""

    def __init__(self, rec) -> None:
        self.rec = rec
        self._collector = EpisodeCollector()

    def on_reset(self, env: MultiCraneEnv) -> None:
        self._collector.on_reset(env)
        self.rec.send_blueprint(blueprint(env.scenario, n_cranes=env.sim.n_cranes))
        log_static(self.rec, env.scenario, env.sim)
        for k in range(env.sim.n_cranes):
            log_lane_style(self.rec, import_rerun(), k)
        self._drawn = 0  # the timeline is drawn up to this time
        self._send_last()

    def on_step(self, env: MultiCraneEnv, actions, reward: float, events) -> None:
        self._collector.on_step(env, actions, reward, events)
        self._send_last()

    def _send_last(self) -> None:
        c = self._collector
        if len(c.steps) == 1:
            self._hooks = home_positions(c.env)
        lo, hi = c.boxes(start=len(c.steps) - 1)
        hooks, cables = crane_geometry(c.env, lo, hi, np.asarray(c.held[-1:]), self._hooks)
        self._hooks = hooks[-1]
        one = EpisodeCollector()
        one.env = c.env
        one.steps, one.status, one.held = c.steps[-1:], c.status[-1:], c.held[-1:]
        one.events = c.events[-1:]
        one.rewards = [sum(c.rewards)]  # the running return
        self._one_step(one, lo[-1], hi[-1], hooks[-1], cables[-1], c.rewards[-1])
        log_timeline(self.rec, c.timeline, c.env.scenario.ids, self._drawn)
        self._drawn = c.timeline.steps

    def _one_step(self, one: EpisodeCollector, lo, hi, hooks, cables, reward: float) -> None:
        rr = import_rerun()
        rec, env = self.rec, one.env
        rec.set_time(TIMELINE, sequence=int(one.steps[0]))
        rec.log(
            "components",
            rr.Boxes3D(centers=(lo + hi) / 2, half_sizes=(hi - lo) / 2,
                       colors=pack_colors(one.status[0], env.sim.site.kind), fill_mode="solid"),
        )  # fmt: skip
        rec.log("cranes/hooks", rr.Points3D(hooks))
        rec.log("cranes/cables", rr.LineStrips3D(cables))
        n = env.sim.site.n_components
        assembled = int((one.status[0] == int(Status.ASSEMBLED)).sum())
        rec.log("metrics/reward", rr.Scalars(reward))
        rec.log("metrics/return", rr.Scalars(one.rewards[0]))
        rec.log("metrics/progress", rr.Scalars(assembled / max(n, 1)))
        for etype, crane, comp in one.events[0]:
            if etype in LOGGED_EVENTS:
                rec.log(
                    "events",
                    rr.TextLog(event_text(env, etype, crane, comp), level=LOGGED_EVENTS[etype]),
                )


def run_live(env: MultiCraneEnv, policy, seed: int, rec, policy_name: str = "") -> EpisodeRecord:
    """Run an episode while streaming it step by step to ``rec``; returns its record."""
    return record_episode(env, policy, seed, policy_name, listeners=[LiveViewer(rec)])


def record_and_save(
    env: MultiCraneEnv,
    policy,
    seed: int,
    rrd: str | Path | None = None,
    policy_name: str = "",
    listeners: Sequence = (),
    play_state: str | None = None,
) -> EpisodeRecord:
    """Run an episode, collecting it as it runs, and write the .rrd at the end (no
    re-simulation); returns the episode record."""
    collector = EpisodeCollector()
    record = record_episode(env, policy, seed, policy_name, listeners=[collector, *listeners])
    if rrd is not None:
        save_collected(
            collector, rrd, name=_name(record), recording_id=_rid(record), play_state=play_state
        )
    return record


__all__ = [
    "APPLICATION_ID",
    "PANEL_STATE_COLORS",
    "STATE_COLORS",
    "EpisodeCollector",
    "LiveViewer",
    "blueprint",
    "connect",
    "log_static",
    "new_recording",
    "pack_colors",
    "record_and_save",
    "record_to_rrd",
    "run_live",
    "save_collected",
    "send_record",
]
