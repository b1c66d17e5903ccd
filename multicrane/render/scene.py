"""The fixed part of a 3D replay: rerun import, state colours, static site, panel blueprint.

A cell ``(x, y, z)`` is drawn as the unit cube ``[x, x+1] x [y, y+1] x [z-1, z]``, so the
ground is the plane ``z = 0``. rerun is imported lazily, inside the functions.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from multicrane.core.kinds import FRAME_COLORS, KINDS, PANEL_COLORS

if TYPE_CHECKING:
    from multicrane.core.schema import Scenario

APPLICATION_ID = "multicrane"
TIMELINE = "step"

# Colours by component state (RGBA, rows by ``Status``), as in the paper's figures; panels
# (slabs, walls) get their own, so they stand out from the frame. Each kind's colours are its
# entry's ``colors`` in ``multicrane.core.kinds``.
STATE_COLORS = np.array(FRAME_COLORS, dtype=np.uint8)
PANEL_STATE_COLORS = np.array(PANEL_COLORS, dtype=np.uint8)


def import_rerun():
    try:
        import rerun
    except ImportError as exc:
        raise ImportError(
            "multicrane.replay.viewer needs rerun-sdk 0.41: pip install 'multicrane[replay]' "
            "(or pip install 'rerun-sdk>=0.41,<0.42')"
        ) from exc
    return rerun


def pack_colors(status: np.ndarray, kinds=None) -> np.ndarray:
    """Component states -> packed ``0xRRGGBBAA`` colours (uint32), any shape; ``kinds`` (the
    components' kind codes, broadcast against ``status``) colours each by its kind's entry
    (panels differ from the frame); without it every component has the frame's colours."""
    status = np.asarray(status, dtype=np.intp)
    if kinds is None:
        rgba = STATE_COLORS[status].astype(np.uint32)
    else:
        palette = np.zeros((max(KINDS) + 1, len(STATE_COLORS), 4), dtype=np.uint32)
        for code, spec in KINDS.items():
            palette[code] = spec.colors
        rgba = palette[np.broadcast_to(np.asarray(kinds, dtype=np.intp), status.shape), status]
    return (rgba[..., 0] << 24) | (rgba[..., 1] << 16) | (rgba[..., 2] << 8) | rgba[..., 3]


def _box(lo, hi) -> tuple[list[float], list[float]]:
    lo, hi = np.asarray(lo, dtype=np.float32), np.asarray(hi, dtype=np.float32)
    return ((lo + hi) / 2).tolist(), ((hi - lo) / 2).tolist()


def log_static(rec, scenario: Scenario, sim) -> None:
    """The site, logged once with ``static=True``."""
    rr = import_rerun()
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
    for cells in sim.site.target_cells:
        xyz = np.array([sim.site.cell(j) for j in cells], dtype=np.float32)
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


def crane_lane(crane: int) -> str:
    """The entity of a crane's activity lane (``multicrane.replay.timeline``'s codes)."""
    return f"cranes/crane_{crane}/activity"


def crane_log(crane: int) -> str:
    """The entity of a crane's text log of its timeline (one line as each interval starts)."""
    return f"cranes/crane_{crane}/log"


def blueprint(scenario: Scenario, play_state: str | None = None, n_cranes: int = 0):
    """3D view (left) beside the metric plots and the event log (right); ``play_state``
    (``"paused"``, ``"playing"``, ``"following"``) sets the time panel's initial state.
    ``n_cranes`` cranes get a timeline: an activity lane each under the 3D view and their text
    logs on the right (0: no timeline)."""
    import_rerun()
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
        contents=["site/**", "components", "cranes/hooks", "cranes/cables"],
        eye_controls=eye,
    )
    side = [
        rrb.TimeSeriesView(name="return", origin="metrics/return"),
        rrb.TimeSeriesView(name="progress", origin="metrics/progress"),
        rrb.TimeSeriesView(name="reward", origin="metrics/reward"),
        rrb.TextLogView(name="events", origin="events"),
    ]
    if n_cranes:
        lanes = [
            rrb.TimeSeriesView(
                name=f"crane_{k}",
                origin=crane_lane(k),
                axis_y=rrb.ScalarAxis(range=(-1.5, 3.5), zoom_lock=True),
            )
            for k in range(n_cranes)
        ]
        view = rrb.Vertical(view, *lanes, row_shares=[1.5 * n_cranes] + [1] * n_cranes)
        side.append(
            rrb.TextLogView(
                name="cranes", origin="cranes", contents=[crane_log(k) for k in range(n_cranes)]
            )
        )
    right = rrb.Vertical(*side, row_shares=[1, 1, 1, 2, 2][: len(side)])
    return rrb.Blueprint(
        rrb.Horizontal(view, right, column_shares=[3, 1]),
        rrb.TimePanel(timeline=TIMELINE, play_state=play_state, state="collapsed"),
        collapse_panels=True,
    )
