"""The Gantt chart of an episode (``multicrane.reports.gantt``): lanes, bars, the PNG file."""

from __future__ import annotations

import pytest

from multicrane.replay.timeline import Interval

pytest.importorskip("matplotlib")

from multicrane.reports.gantt import COLORS, gantt_figure, write_gantt  # noqa: E402

INTERVALS = [
    Interval(0, 0, 5, "lift", 0),
    Interval(0, 5, 6, "assemble", 0),
    Interval(0, 6, 20, "wait"),
    Interval(1, 0, 8, "down"),
    Interval(1, 8, 19, "lift", 1),
    Interval(1, 19, 20, "assemble", 1),
]


def test_lanes_and_bars():
    fig = gantt_figure(INTERVALS, ids=("c1", "b1"), title="micro")
    (ax,) = fig.axes
    assert [t.get_text() for t in ax.get_yticklabels()] == ["crane_0", "crane_1"]
    assert ax.get_xlim() == (0, 20)
    # One collection per (activity, crane) with bars; each bar an interval, in its colour.
    bars = {}
    for collection in ax.collections:
        colour = tuple(collection.get_facecolor()[0])
        what = next(w for w, c in COLORS.items() if c == pytest.approx(colour))
        for path in collection.get_paths():
            (x0, y0), (x1, y1) = path.vertices.min(axis=0), path.vertices.max(axis=0)
            bars[(round((y0 + y1) / 2), round(x0), round(x1))] = what
    assert bars == {(iv.crane, iv.start, iv.end): iv.what for iv in INTERVALS}
    labels = sorted(t.get_text() for t in ax.texts)
    assert labels == ["b1", "c1"]  # the lifts wide enough; assemblies are short
    assert [t.get_text() for t in ax.get_legend().get_texts()] == [
        "lift", "assembly", "waits", "down"
    ]  # fmt: skip


def test_png_file(tmp_path):
    path = write_gantt(INTERVALS, tmp_path / "plan.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
