"""A Gantt chart of an episode: cranes as lanes, each lift and assembly a bar, idle time shown.

    from multicrane.replay.timeline import timeline_of
    from multicrane.reports.gantt import write_gantt
    write_gantt(timeline_of(record), "plan.png", ids=scenario.ids, title="hall-4c")

The bars are the intervals of ``multicrane.replay.timeline`` (steps on the x axis): lifts in
the in-transit blue of the replays, assemblies in their assembled pink, an arrived component
held in their arrived green, waits light grey and breakdowns red; a lift or assembly bar wide
enough carries its component's id. matplotlib (the ``bench`` extra) is imported only for a
picture, through its object API with the Agg canvas. ``write_gantt`` to a ``.html`` file writes
``gantt_html``: a self-contained page (no script, no download) with the chart as inline SVG,
one ``<rect class="bar ...">`` per interval with its crane, times and component as ``data-``
attributes and a tooltip, built here from the intervals alone (no matplotlib needed).
"""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from multicrane.core.kinds import FRAME_COLORS
from multicrane.files import write_atomic
from multicrane.replay.timeline import ASSEMBLE, DOWN, HOLD, LIFT, WAIT, Interval, describe

if TYPE_CHECKING:
    from multicrane.replay.record import EpisodeRecord

_RGBA = {LIFT: FRAME_COLORS[1], HOLD: FRAME_COLORS[2], ASSEMBLE: FRAME_COLORS[3]}
COLORS = {what: tuple(v / 255 for v in rgba) for what, rgba in _RGBA.items()}
COLORS[WAIT] = (0.85, 0.85, 0.85, 1.0)
COLORS[DOWN] = (0.85, 0.15, 0.15, 1.0)
HTML_SUFFIXES = (".html", ".htm")  # write_gantt: a page; any other suffix: a picture
LABELS = {LIFT: "lift", HOLD: "holds arrived", ASSEMBLE: "assembly", WAIT: "waits", DOWN: "down"}


def gantt_figure(intervals: Sequence[Interval], ids: Sequence[str] = (), title: str = ""):
    """The chart as a matplotlib ``Figure`` (lane ``k`` is ``crane_k``, crane 0 on top)."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        from matplotlib.patches import Patch
    except ImportError:
        raise RuntimeError("the chart needs matplotlib: pip install 'multicrane[bench]'") from None
    n_cranes = max((iv.crane for iv in intervals), default=-1) + 1
    steps = max((iv.end for iv in intervals), default=0)
    fig = Figure(figsize=(min(4 + steps / 25, 16), 1 + 0.6 * max(n_cranes, 1)))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot(1, 1, 1)
    for what in COLORS:
        mine = [iv for iv in intervals if iv.what == what]
        for k in range(n_cranes):
            bars = [(iv.start, iv.steps) for iv in mine if iv.crane == k]
            if bars:
                ax.broken_barh(bars, (k - 0.4, 0.8), facecolors=COLORS[what])
    for iv in intervals:
        if iv.what in (LIFT, ASSEMBLE) and ids and iv.steps >= max(steps / 40, 2):
            ax.text((iv.start + iv.end) / 2, iv.crane, ids[iv.component],
                    ha="center", va="center", fontsize=7)  # fmt: skip
    ax.set_yticks(range(n_cranes), [f"crane_{k}" for k in range(n_cranes)])
    ax.set_ylim(n_cranes - 0.5, -0.5)
    ax.set_xlim(0, max(steps, 1))
    ax.set_xlabel("step")
    if title:
        ax.set_title(title)
    shown = [w for w in COLORS if any(iv.what == w for iv in intervals)]
    ax.legend(
        handles=[Patch(facecolor=COLORS[w], label=LABELS[w]) for w in shown],
        loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=8, frameon=False,
    )  # fmt: skip
    fig.tight_layout()
    return fig


def write_gantt(
    intervals: Sequence[Interval], path: str | Path, ids: Sequence[str] = (), title: str = ""
) -> Path:
    """Write the chart to ``path`` and return it: ``.html`` (or ``.htm``) the page of
    ``gantt_html``, any other suffix a matplotlib picture of that format (PNG, SVG, PDF)."""
    path = Path(path)
    if path.suffix.lower() in HTML_SUFFIXES:
        write_atomic(path, gantt_html(intervals, ids, title))
    else:
        gantt_figure(intervals, ids, title).savefig(path, dpi=120)
    return path


def record_title(record: EpisodeRecord) -> str:
    """A chart title for a record's episode: scenario, policy, seed, cranes, steps."""
    policy = f", {record.policy}" if record.policy else ""
    return (f"{record.scenario}{policy}, seed {record.seed}, {record.n_cranes} crane(s), "
            f"{record.steps} steps")  # fmt: skip


# The HTML page's chart, in pixels.
_LEFT, _TOP, _RIGHT, _LANE, _BAR, _AXIS = 72, 8, 16, 28, 20, 34


def gantt_html(intervals: Sequence[Interval], ids: Sequence[str] = (), title: str = "") -> str:
    """The chart as a self-contained HTML page: inline SVG, one ``rect.bar`` per interval
    (``data-crane``, ``data-start``, ``data-end``, ``data-what``, ``data-component``), its
    tooltip the crane's log line and steps; a legend of the activities shown."""
    n_cranes = max((iv.crane for iv in intervals), default=-1) + 1
    steps = max((iv.end for iv in intervals), default=0)
    scale = min(max(1000 / max(steps, 1), 2.0), 14.0)  # pixels per step
    width = _LEFT + steps * scale + _RIGHT
    height = _TOP + n_cranes * _LANE + _AXIS
    last = max((iv.component for iv in intervals), default=-1)
    names = list(ids) or [f"#{j}" for j in range(last + 1)]  # component ids, or indices
    svg = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0f}" height="{height}" '
           f'viewBox="0 0 {width:.0f} {height}" font-family="sans-serif" font-size="11">']
    for k in range(n_cranes):
        y = _TOP + k * _LANE + _LANE / 2
        svg.append(f'<text x="{_LEFT - 6}" y="{y:.1f}" text-anchor="end" '
                   f'dominant-baseline="middle">crane_{k}</text>')  # fmt: skip
    svg += [_bar(iv, names, scale) for iv in intervals]
    svg += _axis(steps, scale, _TOP + n_cranes * _LANE)
    svg.append("</svg>")
    shown = [w for w in COLORS if any(iv.what == w for iv in intervals)]
    legend = " ".join(f'<span class="key"><span class="swatch" style="background:{_css(w)}">'
                      f"</span>{LABELS[w]}</span>" for w in shown)  # fmt: skip
    head = html.escape(title or "Gantt chart")
    return "\n".join([
        "<!DOCTYPE html>", '<html lang="en">', '<head><meta charset="utf-8">',
        f"<title>{head}</title>",
        "<style>body{font-family:sans-serif;margin:16px} .key{margin-right:14px}"
        " .swatch{display:inline-block;width:12px;height:12px;margin-right:4px;"
        "vertical-align:middle} rect.bar:hover{stroke:#000}</style>",
        "</head><body>", f"<h3>{head}</h3>", *svg, f"<p>{legend}</p>", "</body></html>", "",
    ])  # fmt: skip


def _css(what: str) -> str:
    r, g, b = (round(255 * v) for v in COLORS[what][:3])
    return f"#{r:02x}{g:02x}{b:02x}"


def _bar(iv: Interval, names: Sequence[str], scale: float) -> str:
    """One interval: its rect with data attributes and tooltip, and its component's id on a
    lift or assembly bar wide enough for it."""
    x, w = _LEFT + iv.start * scale, iv.steps * scale
    y = _TOP + iv.crane * _LANE + (_LANE - _BAR) / 2
    when = f"steps {iv.start + 1}-{iv.end}" if iv.steps > 1 else f"step {iv.end}"
    tip = html.escape(f"crane_{iv.crane}: {describe(iv, names)}, {when}")
    out = (f'<rect class="bar {iv.what}" x="{x:.1f}" y="{y:.1f}" width="{w:.1f}" '
           f'height="{_BAR}" fill="{_css(iv.what)}" data-crane="{iv.crane}" '
           f'data-start="{iv.start}" data-end="{iv.end}" data-what="{iv.what}" '
           f'data-component="{iv.component}"><title>{tip}</title></rect>')  # fmt: skip
    if iv.what in (LIFT, ASSEMBLE) and w >= 7 * len(names[iv.component]) + 6:
        out += (f'<text x="{x + w / 2:.1f}" y="{y + _BAR / 2:.1f}" text-anchor="middle" '
                f'dominant-baseline="middle" font-size="10" pointer-events="none">'
                f"{html.escape(names[iv.component])}</text>")  # fmt: skip
    return out


def _axis(steps: int, scale: float, y: float) -> list[str]:
    """The step axis under the lanes: a line, ticks about every 80 pixels, and its label."""
    raw = 80 / scale
    power = 10 ** math.floor(math.log10(raw))
    every = next(m * power for m in (1, 2, 5, 10) if m * power >= raw)
    right = _LEFT + steps * scale
    out = [f'<line x1="{_LEFT}" y1="{y}" x2="{right:.1f}" y2="{y}" stroke="#555"/>']
    for t in range(0, steps + 1, max(int(every), 1)):
        x = _LEFT + t * scale
        out.append(f'<line x1="{x:.1f}" y1="{y}" x2="{x:.1f}" y2="{y + 4}" stroke="#555"/>'
                   f'<text x="{x:.1f}" y="{y + 15}" text-anchor="middle">{t}</text>')  # fmt: skip
    out.append(f'<text x="{(_LEFT + right) / 2:.1f}" y="{y + 30}" text-anchor="middle">'
               "step</text>")  # fmt: skip
    return out


__all__ = ["COLORS", "HTML_SUFFIXES", "gantt_figure", "gantt_html", "record_title", "write_gantt"]
