"""3D replays of episodes with rerun (``pip install "multicrane[replay]"``).

    from multicrane.viewer import record_to_rrd, LiveViewer
    record_to_rrd(record, "episode.rrd")          # an EpisodeRecord, re-simulated, to a file

Entities (one timeline, ``step``; step 0 is the state after reset):

- ``site/ground``, ``site/construction_area``, ``site/foundations``, ``site/obstacles``,
  ``site/targets`` (wireframes): static.
- ``components``: one box per component (scenario order), coloured by state as in the
  paper: initial orange, in transit blue, arrived green, assembled pink.
- ``cranes/hooks`` (a point labelled ``crane_i`` above what each crane holds; an idle crane
  stays where it last was) and ``cranes/cables`` (hook to component).
- ``metrics/reward``, ``metrics/return``, ``metrics/progress`` (assembled fraction).
- ``events``: a text log of claims, blocked moves, arrivals and assemblies.

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

from multicrane.record import EpisodeRecord, EventRow, record_episode, replay_steps
from multicrane.types import Status

if TYPE_CHECKING:
    from multicrane.crane_env import MultiCraneEnv
    from multicrane.scenario import Scenario

APPLICATION_ID = "multicrane"
TIMELINE = "step"

# Colours by component state (RGBA), as in the paper's figures.
STATE_COLORS = np.array(
    [
        [255, 153, 0, 255],  # initial: orange
        [40, 110, 255, 255],  # in transit: blue
        [50, 190, 70, 255],  # arrived: green
        [240, 110, 180, 255],  # assembled: pink
    ],
    dtype=np.uint8,
)
assert len(STATE_COLORS) == len(Status)

# Events shown in the text log, with their level.
LOGGED_EVENTS = {
    "CLAIMED": "INFO",
    "ARRIVED": "INFO",
    "ASSEMBLED": "INFO",
    "BLOCKED": "WARN",
    "LIFT_BLOCKED": "WARN",
    "CLAIM_CONFLICT": "WARN",
    "ILLEGAL": "WARN",
}


def _rerun():
    try:
        import rerun
    except ImportError as exc:
        raise ImportError(
            "multicrane.viewer needs rerun-sdk 0.41: pip install 'multicrane[replay]' "
            "(or pip install 'rerun-sdk>=0.41,<0.42')"
        ) from exc
    return rerun


def pack_colors(status: np.ndarray) -> np.ndarray:
    """Component states -> packed ``0xRRGGBBAA`` colours (uint32), any shape."""
    rgba = STATE_COLORS[np.asarray(status, dtype=np.intp)].astype(np.uint32)
    return (rgba[..., 0] << 24) | (rgba[..., 1] << 16) | (rgba[..., 2] << 8) | rgba[..., 3]


# ---------------------------------------------------------------------------------------------
# Collecting an episode as arrays (no rerun needed)


class EpisodeCollector:
    """A ``StepObserver`` that keeps, per step, what the replay draws.

    Pass it to ``record_episode(..., observers=[collector])`` or ``replay_steps``; then
    ``send(rec)`` logs everything with ``send_columns``.
    """

    def __init__(self) -> None:
        self.env: MultiCraneEnv | None = None

    def on_reset(self, env: MultiCraneEnv) -> None:
        self.env = env
        self.steps: list[int] = []
        self.status: list[np.ndarray] = []
        self.cells: list[list[list[int]]] = []  # per step, each component's cell list
        self.held: list[list[int]] = []
        self.rewards: list[float] = []
        self.events: list[list[EventRow]] = []
        self._capture(0.0, [])

    def on_step(self, env: MultiCraneEnv, actions: list[int], reward: float, events) -> None:
        self._capture(reward, events)

    def _capture(self, reward: float, events: list[EventRow]) -> None:
        # Cheap on purpose: the simulator replaces a moved component's cell list (it never
        # mutates one), so keeping references is enough; boxes are computed in ``boxes``.
        sim = self.env.sim
        self.steps.append(sim.step_count)
        self.status.append(sim.status.copy())
        self.cells.append(list(sim.cells))
        self.held.append(list(sim.held))
        self.rewards.append(reward)
        self.events.append(events)

    def boxes(self, start: int = 0) -> tuple[np.ndarray, np.ndarray]:
        """Box corners ``lo, hi`` (T, C, 3) of every component from step index ``start``."""
        sim = self.env.sim
        per_step = self.cells[start:]
        T, n = len(per_step), sim.n_components
        lo = np.empty((T, n, 3), dtype=np.float32)
        hi = np.empty((T, n, 3), dtype=np.float32)
        last: list = [None] * n
        lo_now = np.zeros((n, 3), dtype=np.float32)
        hi_now = np.zeros((n, 3), dtype=np.float32)
        cell = sim.cell
        for t, cells in enumerate(per_step):
            for i, c in enumerate(cells):
                if c is not last[i]:
                    last[i] = c
                    # A component is a straight run of cells: the smallest and largest
                    # linear indices are its two corner cells.
                    lo_now[i] = cell(min(c))
                    hi_now[i] = cell(max(c))
            lo[t] = lo_now
            hi[t] = hi_now
        lo[..., 2] -= 1
        hi[..., :2] += 1
        return lo, hi

    # -- sending -----------------------------------------------------------------------------

    def send(self, rec, static: bool = True) -> None:
        """Log the collected episode to ``rec`` (a RecordingStream): static site (unless
        ``static=False``), then every time series with one ``send_columns`` per entity."""
        rr = _rerun()
        env = self.env
        if env is None:
            raise RuntimeError("nothing collected: the collector never saw a reset")
        if static:
            log_static(rec, env.scenario, env.sim)
        steps = np.asarray(self.steps, dtype=np.int64)
        T, n = len(steps), env.sim.n_components
        time = [rr.TimeColumn(TIMELINE, sequence=steps)]
        lo, hi = self.boxes()
        status = np.stack(self.status)
        rec.send_columns(
            "components",
            indexes=time,
            columns=rr.Boxes3D.columns(
                centers=((lo + hi) / 2).reshape(-1, 3),
                half_sizes=((hi - lo) / 2).reshape(-1, 3),
                colors=pack_colors(status).reshape(-1),
            ).partition([n] * T),
        )
        hooks, cables = crane_geometry(env, lo, hi, np.asarray(self.held))
        k = env.sim.n_cranes
        rec.send_columns(
            "cranes/hooks",
            indexes=time,
            columns=rr.Points3D.columns(positions=hooks.reshape(-1, 3)).partition([k] * T),
        )
        rec.send_columns(
            "cranes/cables",
            indexes=time,
            columns=rr.LineStrips3D.columns(strips=cables.reshape(-1, 2, 3)).partition([k] * T),
        )
        rewards = np.asarray(self.rewards)
        placed = (status == int(Status.ASSEMBLED)).sum(axis=1)
        for name, values in (
            ("reward", rewards),
            ("return", np.cumsum(rewards)),
            ("progress", placed / max(n, 1)),
        ):
            rec.send_columns(
                f"metrics/{name}", indexes=time, columns=rr.Scalars.columns(scalars=values)
            )
        texts, levels, at = [], [], []
        for t, events in zip(steps, self.events, strict=True):
            for etype, crane, comp in events:
                if etype in LOGGED_EVENTS:
                    texts.append(_event_text(env, etype, crane, comp))
                    levels.append(LOGGED_EVENTS[etype])
                    at.append(t)
        if texts:
            rec.send_columns(
                "events",
                indexes=[rr.TimeColumn(TIMELINE, sequence=np.asarray(at, dtype=np.int64))],
                columns=rr.TextLog.columns(text=texts, level=levels),
            )


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


def _event_text(env: MultiCraneEnv, etype: str, crane: int, comp: int) -> str:
    what = env.scenario.components[comp].id if comp >= 0 else "-"
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


# ---------------------------------------------------------------------------------------------
# Static site and blueprint


def _box(lo, hi) -> tuple[list[float], list[float]]:
    lo, hi = np.asarray(lo, dtype=np.float32), np.asarray(hi, dtype=np.float32)
    return ((lo + hi) / 2).tolist(), ((hi - lo) / 2).tolist()


def log_static(rec, scenario: Scenario, sim) -> None:
    """The site, logged once with ``static=True``."""
    rr = _rerun()
    X, Y, H = scenario.size
    rec.log("/", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    c, h = _box((0, 0, -0.2), (X, Y, -0.02))
    rec.log(
        "site/ground",
        rr.Boxes3D(centers=[c], half_sizes=[h], colors=[(200, 185, 150)], labels=["yard"],
                   fill_mode="solid", show_labels=False),
        static=True,
    )  # fmt: skip
    x0, y0, x1, y1 = scenario.construction_area
    c, h = _box((x0, y0, -0.02), (x1 + 1, y1 + 1, 0.0))
    rec.log(
        "site/construction_area",
        rr.Boxes3D(centers=[c], half_sizes=[h], colors=[(150, 150, 160)],
                   labels=["construction area"], fill_mode="solid", show_labels=False),
        static=True,
    )  # fmt: skip
    if scenario.foundations:
        boxes = [
            _box((x + 0.1, y + 0.1, 0.0), (x + 0.9, y + 0.9, 0.15)) for x, y in scenario.foundations
        ]
        rec.log(
            "site/foundations",
            rr.Boxes3D(centers=[b[0] for b in boxes], half_sizes=[b[1] for b in boxes],
                       colors=[(90, 90, 90)], fill_mode="solid"),
            static=True,
        )  # fmt: skip
    if scenario.obstacles:
        boxes = [
            _box((b.lo[0], b.lo[1], b.lo[2] - 1), (b.hi[0] + 1, b.hi[1] + 1, b.hi[2]))
            for b in scenario.obstacles
        ]
        rec.log(
            "site/obstacles",
            rr.Boxes3D(centers=[b[0] for b in boxes], half_sizes=[b[1] for b in boxes],
                       colors=[(110, 80, 60)], fill_mode="solid"),
            static=True,
        )  # fmt: skip
    boxes = []
    for cells in sim.target_cells:
        xyz = np.array([sim.cell(j) for j in cells], dtype=np.float32)
        boxes.append(_box(xyz.min(axis=0) - (0, 0, 1), xyz.max(axis=0) + (1, 1, 0)))
    rec.log(
        "site/targets",
        rr.Boxes3D(centers=[b[0] for b in boxes], half_sizes=[b[1] for b in boxes],
                   colors=[(120, 120, 120, 160)], fill_mode="majorwireframe",
                   labels=[c.id for c in scenario.components], show_labels=False),
        static=True,
    )  # fmt: skip
    rec.log(
        "cranes/hooks",
        rr.Points3D.from_fields(
            radii=[0.45], colors=[(255, 220, 0)],
            labels=[f"crane_{i}" for i in range(sim.n_cranes)], show_labels=True,
        ),
        static=True,
    )  # fmt: skip
    rec.log(
        "cranes/cables",
        rr.LineStrips3D.from_fields(radii=[0.06], colors=[(255, 220, 0)]),
        static=True,
    )
    rec.log(
        "components",
        rr.Boxes3D.from_fields(
            fill_mode="solid", labels=[c.id for c in scenario.components], show_labels=False
        ),
        static=True,
    )


def blueprint(scenario: Scenario, play_state: str | None = None):
    """3D view (left) beside the metric plots and the event log (right); ``play_state``
    (``"paused"``, ``"playing"``, ``"following"``) sets the time panel's initial state."""
    _rerun()
    import rerun.blueprint as rrb

    X, Y, H = scenario.size
    centre = (X / 2, Y / 2, H / 3)
    eye = rrb.archetypes.EyeControls3D(
        kind=rrb.components.Eye3DKind.Orbital,
        position=(X * 0.9, -Y * 0.35, H + 0.55 * max(X, Y)),
        look_target=centre,
        eye_up=(0, 0, 1),
    )
    view = rrb.Spatial3DView(
        name="site",
        origin="/",
        contents=["site/**", "components", "cranes/**"],
        eye_controls=eye,
    )
    side = rrb.Vertical(
        rrb.TimeSeriesView(name="return", origin="metrics/return"),
        rrb.TimeSeriesView(name="progress", origin="metrics/progress"),
        rrb.TimeSeriesView(name="reward", origin="metrics/reward"),
        rrb.TextLogView(name="events", origin="events"),
        row_shares=[1, 1, 1, 2],
    )
    return rrb.Blueprint(
        rrb.Horizontal(view, side, column_shares=[3, 1]),
        rrb.TimePanel(timeline=TIMELINE, play_state=play_state, state="collapsed"),
        collapse_panels=True,
    )


# ---------------------------------------------------------------------------------------------
# Recording streams and the three uses


def new_recording(name: str = "", recording_id: str | None = None):
    """A RecordingStream for one episode, with the automatic wall-clock timeline off."""
    rr = _rerun()
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
    for _ in replay_steps(record, observers=[collector]):
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
    rec.save(path, default_blueprint=blueprint(collector.env.scenario, play_state))
    collector.send(rec)
    rec.flush()
    rec.disconnect()
    return path


def send_record(record: EpisodeRecord, rec) -> None:
    """Re-simulate a record and send it to an already connected stream."""
    collector = EpisodeCollector()
    for _ in replay_steps(record, observers=[collector]):
        pass
    rec.send_blueprint(blueprint(collector.env.scenario))
    collector.send(rec)


def connect(rec, url: str | None = None, spawn: bool = False, scenario: Scenario | None = None):
    """Connect a stream to a viewer: ``spawn`` one, or the running one at ``url``."""
    bp = blueprint(scenario) if scenario is not None else None
    if spawn:
        rec.spawn(default_blueprint=bp)
    else:
        rec.connect_grpc(url, default_blueprint=bp)
    return rec


class LiveViewer:
    """A ``StepObserver`` that logs each step to a stream as the environment runs."""

    def __init__(self, rec) -> None:
        self.rec = rec
        self._collector = EpisodeCollector()

    def on_reset(self, env: MultiCraneEnv) -> None:
        self._collector.on_reset(env)
        self.rec.send_blueprint(blueprint(env.scenario))
        log_static(self.rec, env.scenario, env.sim)
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

    def _one_step(self, one: EpisodeCollector, lo, hi, hooks, cables, reward: float) -> None:
        rr = _rerun()
        rec, env = self.rec, one.env
        rec.set_time(TIMELINE, sequence=int(one.steps[0]))
        rec.log(
            "components",
            rr.Boxes3D(centers=(lo + hi) / 2, half_sizes=(hi - lo) / 2,
                       colors=pack_colors(one.status[0]), fill_mode="solid"),
        )  # fmt: skip
        rec.log("cranes/hooks", rr.Points3D(hooks))
        rec.log("cranes/cables", rr.LineStrips3D(cables))
        n = env.sim.n_components
        placed = int((one.status[0] == int(Status.ASSEMBLED)).sum())
        rec.log("metrics/reward", rr.Scalars(reward))
        rec.log("metrics/return", rr.Scalars(one.rewards[0]))
        rec.log("metrics/progress", rr.Scalars(placed / max(n, 1)))
        for etype, crane, comp in one.events[0]:
            if etype in LOGGED_EVENTS:
                rec.log(
                    "events",
                    rr.TextLog(_event_text(env, etype, crane, comp), level=LOGGED_EVENTS[etype]),
                )


def run_live(env: MultiCraneEnv, policy, seed: int, rec, policy_name: str = "") -> EpisodeRecord:
    """Run an episode while streaming it step by step to ``rec``; returns its record."""
    return record_episode(env, policy, seed, policy_name, observers=[LiveViewer(rec)])


def record_and_save(
    env: MultiCraneEnv,
    policy,
    seed: int,
    rrd: str | Path | None = None,
    policy_name: str = "",
    observers: Sequence = (),
    play_state: str | None = None,
) -> EpisodeRecord:
    """Run an episode, collecting it as it runs, and write the .rrd at the end (no
    re-simulation); returns the episode record."""
    collector = EpisodeCollector()
    record = record_episode(env, policy, seed, policy_name, observers=[collector, *observers])
    if rrd is not None:
        save_collected(
            collector, rrd, name=_name(record), recording_id=_rid(record), play_state=play_state
        )
    return record


__all__ = [
    "APPLICATION_ID",
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
