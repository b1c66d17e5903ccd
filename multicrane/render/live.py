"""``render_mode="human"``: each reset and step of an environment streamed to a rerun viewer.

The stream goes where ``MULTICRANE_RERUN_SINK`` says: unset or ``spawn`` starts the native
viewer (``rerun`` from the ``replay`` extra, on PATH or beside the running Python); a
``rerun+http://...`` address connects to a running one (``rerun --serve-web`` or a viewer on
another machine); ``memory`` keeps it in memory (headless runs and tests: nothing is shown,
nothing blocks). With no viewer to reach (none installed, no display, nothing listening at
the address) the environment warns in one line and runs on without one
(``multicrane.render.viewers``). The drawing is that of ``multicrane.replay.viewer``
(components coloured by state, the static site, the panels); rerun is imported on first use,
with a one-line error naming the extra when it is missing.
"""

from __future__ import annotations

import os
import warnings

import numpy as np

from multicrane.render.scene import (
    APPLICATION_ID,
    TIMELINE,
    blueprint,
    import_rerun,
    log_static,
    pack_colors,
)
from multicrane.render.viewers import NoViewer, connect_viewer, spawn_viewer

SINK_VARIABLE = "MULTICRANE_RERUN_SINK"


class LiveView:
    """One recording stream, fed by an environment's ``reset`` and ``step``."""

    def __init__(self, sink: str | None = None) -> None:
        rr = import_rerun()
        self.rr = rr
        self.rec = rr.RecordingStream(APPLICATION_ID)
        self.rec.set_log_time_enabled(False)
        self.rec.set_log_tick_enabled(False)
        self.sink = sink if sink is not None else os.environ.get(SINK_VARIABLE, "spawn")
        self._connected = False
        self.shown = True  # False once no viewer could be reached: nothing is logged then
        self._return = 0.0

    def _connect(self, scenario) -> None:
        bp = blueprint(scenario)
        self._connected = True
        try:
            if self.sink == "memory":
                self.storage = self.rec.memory_recording()
            elif self.sink == "spawn":
                spawn_viewer(self.rec, bp)
            else:
                connect_viewer(self.rec, self.sink, bp)
        except NoViewer as exc:
            self.shown = False
            warnings.warn(f"render_mode='human' shows nothing: {exc}", stacklevel=4)

    def reset(self, env) -> None:
        if not self._connected:
            self._connect(env.scenario)
        if self.shown:
            log_static(self.rec, env.scenario, env.sim)
            self._return = 0.0
            self._log(env, 0.0)

    def step(self, env, reward: float) -> None:
        if self.shown:
            self._return += reward
            self._log(env, reward)

    def _log(self, env, reward: float) -> None:
        rr, rec, sim = self.rr, self.rec, env.sim
        st = sim.state
        rec.set_time(TIMELINE, sequence=int(st.step_count))
        n = sim.site.n_components
        lo = np.zeros((n, 3), dtype=np.float32)
        hi = np.zeros((n, 3), dtype=np.float32)
        for i, cells in enumerate(st.cells):
            if cells:
                lo[i] = sim.site.cell(min(cells))
                hi[i] = sim.site.cell(max(cells))
        lo[:, 2] -= 1
        hi[:, :2] += 1
        rec.log(
            "components",
            rr.Boxes3D(centers=(lo + hi) / 2, half_sizes=(hi - lo) / 2,
                       colors=pack_colors(st.status, sim.site.kind), fill_mode="solid"),
        )  # fmt: skip
        rec.log("metrics/reward", rr.Scalars(reward))
        rec.log("metrics/return", rr.Scalars(self._return))
        rec.log("metrics/progress", rr.Scalars(st.n_assembled / max(n, 1)))

    def close(self) -> None:
        if self.shown:
            self.rec.flush()
