"""Gaps, track summaries, best-known makespans and bounds files of the suite."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from multicrane.suite.bounds import BOUNDS, read_bounds
from multicrane.suite.manifest import Manifest, SuiteError
from multicrane.suite.page import best_known
from multicrane.suite.results import gap, mean, read_results, track_summary, write_results


def test_gap_and_mean():
    assert gap(110, 100) == pytest.approx(10.0)
    assert gap(None, 100) is None and gap(110, None) is None
    assert mean([1.0, 3.0]) == 2.0
    assert mean([1.0, None]) is None and mean([]) is None


def test_a_track_without_every_instance_done_has_no_mean_gap():
    done = {"makespan": 110, "bound": 100, "best_known": 110, "seconds": 1.0}
    s = track_summary([done, {**done, "makespan": 120}])
    assert (s["completed"], s["makespan_mean"]) == (2, 115.0)
    assert s["gap_bound"] == pytest.approx(15.0)
    assert s["gap_best"] == pytest.approx(100 * 10 / 110 / 2)
    s = track_summary([done, {**done, "makespan": None}])
    assert (s["completed"], s["gap_bound"], s["gap_best"]) == (1, None, None)


def test_best_known_takes_the_smallest_and_the_first_on_ties(tmp_path):
    def results(policy, spans):
        entries = [{"id": k, "makespan": v} for k, v in spans.items()]
        return {"policy": policy, "decisions": "motion", "instances": entries}

    collected = [
        {"path": tmp_path / "results" / "a.json", "results": results("a", {"x": 10, "y": 7})},
        {"path": tmp_path / "results" / "b.json", "results": results("b", {"x": 9, "y": 7})},
        {"path": tmp_path / "results" / "c.json", "results": results("c", {"x": None})},
    ]
    best = best_known(collected, tmp_path)
    assert best["x"] == {"makespan": 9, "policy": "b", "decisions": "motion",
                         "results": "results/b.json"}  # fmt: skip
    assert best["y"]["policy"] == "a"


def test_results_files_round_trip_plain_and_gzipped(tmp_path):
    data = {"instances": [{"id": "x", "makespan": 3}], "track": "t"}
    for name in ("r.json", "r.json.gz"):
        assert read_results(write_results(tmp_path / name, data)) == data
    (tmp_path / "bad.json").write_text("{")
    with pytest.raises(SuiteError, match="bad.json: cannot read"):
        read_results(tmp_path / "bad.json")


def test_bounds_of_another_manifest_are_refused(tmp_path: Path):
    manifest = Manifest("t", tmp_path, "a" * 64, ())
    assert read_bounds(manifest) == {}
    (tmp_path / BOUNDS).write_text(json.dumps({"manifest_sha256": "b" * 64, "instances": {}}))
    with pytest.raises(SuiteError, match="computed for another manifest"):
        read_bounds(manifest)
