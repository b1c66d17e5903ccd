"""The Gantt chart as a self-contained HTML page (``multicrane.reports.gantt.gantt_html``):
one SVG bar per interval, its data and tooltip, labels, legend; no matplotlib needed."""

from __future__ import annotations

import xml.etree.ElementTree as ET

from multicrane.replay.timeline import Interval
from multicrane.reports.gantt import COLORS, gantt_html, write_gantt

SVG = "{http://www.w3.org/2000/svg}"
INTERVALS = [
    Interval(0, 0, 5, "lift", 0),
    Interval(0, 5, 6, "assemble", 0),
    Interval(0, 6, 20, "wait"),
    Interval(1, 0, 8, "down"),
    Interval(1, 8, 19, "lift", 1),
    Interval(1, 19, 20, "assemble", 1),
]


def _svg(page: str) -> ET.Element:
    """The page's chart, parsed as XML (it must be well-formed)."""
    return ET.fromstring(page[page.index("<svg") : page.index("</svg>") + len("</svg>")])


def _bars(svg: ET.Element) -> list[ET.Element]:
    return [r for r in svg.iter(f"{SVG}rect") if r.get("class", "").startswith("bar ")]


def test_one_bar_per_interval_with_its_data():
    page = gantt_html(INTERVALS, ids=("c1", "b1"), title="micro <frame>")
    assert page.startswith("<!DOCTYPE html>") and "<script" not in page and "http" not in (
        page.replace('xmlns="http://www.w3.org/2000/svg"', ""))  # fmt: skip
    assert "<title>micro &lt;frame&gt;</title>" in page
    bars = _bars(_svg(page))
    got = [(int(b.get("data-crane")), int(b.get("data-start")), int(b.get("data-end")),
            b.get("data-what"), int(b.get("data-component"))) for b in bars]  # fmt: skip
    assert got == [(iv.crane, iv.start, iv.end, iv.what, iv.component) for iv in INTERVALS]
    scale = {float(b.get("width")) / (int(b.get("data-end")) - int(b.get("data-start")))
             for b in bars}  # fmt: skip
    assert len({round(s, 6) for s in scale}) == 1  # widths proportional to the steps
    ys = {int(b.get("data-crane")): float(b.get("y")) for b in bars}
    assert ys[0] < ys[1]  # crane 0 on top
    for b in bars:
        r, g, bl = (round(255 * v) for v in COLORS[b.get("data-what")][:3])
        assert b.get("fill") == f"#{r:02x}{g:02x}{bl:02x}"
    tips = [b.find(f"{SVG}title").text for b in bars]
    assert tips[0] == "crane_0: lifts c1, steps 1-5" and tips[1] == "crane_0: assembles c1, step 6"
    assert tips[3] == "crane_1: breaks down, steps 1-8"
    labels = sorted(t.text for t in _svg(page).iter(f"{SVG}text") if t.text in ("c1", "b1"))
    assert labels == ["b1", "c1"]  # the wide lifts carry their ids, the short assemblies not
    legend = page[page.index("</svg>") :]
    assert [w for w in ("lift", "assembly", "waits", "down", "holds") if w in legend] == [
        "lift", "assembly", "waits", "down"
    ]  # fmt: skip


def test_without_ids_and_empty(tmp_path):
    page = gantt_html(INTERVALS)
    assert "lifts #1" in page
    assert _bars(_svg(gantt_html([]))) == []
    path = write_gantt(INTERVALS, tmp_path / "plan.html", ids=("c1", "b1"))
    assert path.read_text(encoding="utf-8") == gantt_html(INTERVALS, ids=("c1", "b1"))
