"""Gantt charts from the command line: ``multicrane plan --gantt`` and ``multicrane gantt
RECORD``, as HTML and PNG, as many bars as the episode's timeline has intervals."""

from __future__ import annotations

import sys

import pytest

from multicrane.cli import main
from multicrane.replay.record import EpisodeRecord
from multicrane.replay.timeline import timeline_of


def _bars(path) -> int:
    return path.read_text(encoding="utf-8").count('<rect class="bar ')


def test_plan_and_record_give_the_same_chart(tmp_path, capsys):
    record, page = tmp_path / "ep.json.gz", tmp_path / "plan.html"
    argv = ["plan", "e2s2", "--cranes", "2", "--policy", "prioritized", "--record", str(record),
            "--gantt", str(page)]  # fmt: skip
    assert main(argv) == 0
    assert f"gantt chart: {page}" in capsys.readouterr().out
    intervals = timeline_of(EpisodeRecord.load(record))
    assert _bars(page) == len(intervals) > 2
    again = tmp_path / "again.html"
    assert main(["gantt", str(record), "-o", str(again)]) == 0
    assert f"({len(intervals)} bars)" in capsys.readouterr().out
    assert again.read_text(encoding="utf-8") == page.read_text(encoding="utf-8")
    assert main(["gantt", str(record), "-o", str(again), "--title", "mine"]) == 0
    assert "<h3>mine</h3>" in again.read_text(encoding="utf-8")


def test_png_from_plan_and_record(tmp_path):
    pytest.importorskip("matplotlib")
    record, png = tmp_path / "ep.json", tmp_path / "plan.png"
    assert main(["plan", "e2s2", "--cranes", "2", "--record", str(record),
                 "--gantt", str(png)]) == 0  # fmt: skip
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    other = tmp_path / "record.png"
    assert main(["gantt", str(record), "-o", str(other)]) == 0
    assert other.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_refusals(tmp_path, capsys, monkeypatch):
    assert main(["gantt", str(tmp_path / "none.json.gz"), "-o", str(tmp_path / "x.html")]) == 2
    err = capsys.readouterr().err.strip()
    assert "none.json.gz" in err and "\n" not in err
    record = tmp_path / "ep.json"
    assert main(["plan", "e2s2", "--policy", "greedy", "--record", str(record)]) == 0
    capsys.readouterr()
    assert main(["gantt", str(record), "-o", str(tmp_path / "no" / "x.html")]) == 2
    assert "cannot write the chart" in capsys.readouterr().err
    assert main(["plan", "e2s2", "--policy", "greedy", "random", "--gantt", "x.html"]) == 2
    assert "--gantt need one policy" in capsys.readouterr().err
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # as without the bench extra
    assert main(["gantt", str(tmp_path / "ep.json"), "-o", str(tmp_path / "x.png")]) == 2
    assert "multicrane gantt needs the 'bench' extra" in capsys.readouterr().err
    assert main(["plan", "e2s2", "--gantt", str(tmp_path / "x.png")]) == 2
    assert "multicrane plan needs the 'bench' extra" in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists()
