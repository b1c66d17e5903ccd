"""multicrane suite evaluate, verify and page, end to end on a two-instance test manifest."""

from __future__ import annotations

import copy
import json

import pytest

from multicrane.cli import main
from multicrane.replay import record_file
from multicrane.suite.manifest import MANIFEST, manifest_text, read_manifest
from multicrane.suite.page import BEST, RESULTS_DIR, read_best
from multicrane.suite.results import read_results, write_results

TINY = ("small-01", "small-events-01")  # 13 components: 3 cranes; 1 crane with low events


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    """A test version: two shipped small instances, as one track ``tiny``."""
    folder = tmp_path_factory.mktemp("tiny-suite")
    shipped = read_manifest("v1")
    rows = []
    for name in TINY:
        row = {**shipped.get(name).row(), "track": "tiny"}
        target = folder / row["file"]
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes((shipped.folder / row["file"]).read_bytes())
        rows.append(row)
    (folder / MANIFEST).write_text(manifest_text("tiny", "a test version", rows))
    return folder


@pytest.fixture(scope="module")
def results(suite, tmp_path_factory):
    """The prioritized planner's results on the track (played by the command)."""
    out = tmp_path_factory.mktemp("results") / "tiny-prioritized.json"
    argv = ["suite", "evaluate", str(suite), "--track", "tiny", "--policy", "prioritized",
            "--out", str(out)]  # fmt: skip
    assert main(argv) == 0
    return out


def test_evaluate_writes_every_instance_with_its_record(results, suite, capsys):
    data = read_results(results)
    manifest = read_manifest(suite)
    assert (data["version"], data["manifest_sha256"]) == ("tiny", manifest.sha256)
    assert (data["track"], data["policy"], data["decisions"]) == ("tiny", "prioritized", "motion")
    assert [e["id"] for e in data["instances"]] == list(TINY)
    for entry in data["instances"]:
        assert entry["success"] and entry["makespan"] == entry["record"]["metrics"]["steps"]
        assert entry["record"]["scenario_sha256"] == manifest.get(entry["id"]).sha256
    assert data["instances"][0]["record"].get("schedule") is None  # no events
    assert data["instances"][1]["record"]["schedule"]  # the drawn low-level events
    assert main(["suite", "verify", str(results)]) == 1  # no shipped version "tiny"
    capsys.readouterr()
    assert main(["suite", "verify", str(results), "--suite", str(suite)]) == 0
    assert "verified (2 instances" in capsys.readouterr().out


def _refused(suite, results, tmp_path, capsys, edit) -> str:
    """Verify a copy of the results changed by ``edit``; the refusal's message."""
    data = copy.deepcopy(read_results(results))
    edit(data)
    forged = write_results(tmp_path / "forged.json", data)
    assert main(["suite", "verify", str(forged), "--suite", str(suite)]) == 1
    return capsys.readouterr().err


def _reseal(record: dict) -> None:
    body = {k: v for k, v in record.items() if k != record_file.CHECKSUM}
    record[record_file.CHECKSUM] = record_file.checksum(body)


def test_a_forged_makespan_is_refused(suite, results, tmp_path, capsys):
    def forge(data):
        data["instances"][1]["makespan"] -= 1

    err = _refused(suite, results, tmp_path, capsys, forge)
    assert "small-events-01: the results say makespan" in err


def test_a_swapped_instance_is_refused(suite, results, tmp_path, capsys):
    def swap(data):
        a, b = data["instances"]
        a["id"], b["id"] = b["id"], a["id"]

    err = _refused(suite, results, tmp_path, capsys, swap)
    assert "small-events-01: the record's scenario sha256" in err


def test_an_edited_record_is_refused(suite, results, tmp_path, capsys):
    def edit(data):
        data["instances"][0]["record"]["actions"][0][0] += 1

    err = _refused(suite, results, tmp_path, capsys, edit)
    assert "small-01: the record was changed after it was written" in err

    def edit_and_reseal(data):
        record = data["instances"][0]["record"]
        record["actions"][0] = [0] * len(record["actions"][0])  # every crane waits
        _reseal(record)

    err = _refused(suite, results, tmp_path, capsys, edit_and_reseal)
    assert "small-01: episode record refused" in err


def test_other_events_seeds_and_instances_are_refused(suite, results, tmp_path, capsys):
    def no_events(data):
        record = data["instances"][1]["record"]
        del record["schedule"]
        _reseal(record)

    assert "small-events-01: the record's site events" in _refused(
        suite, results, tmp_path, capsys, no_events
    )

    def other_seed(data):
        record = data["instances"][0]["record"]
        record["seed"] += 1
        _reseal(record)

    err = _refused(suite, results, tmp_path, capsys, other_seed)
    assert "small-01: the record's reset seed is 1, the instance's 0" in err

    def unknown(data):
        data["instances"][0]["id"] = "small-99"

    assert "small-99: not an instance of multicrane-bench tiny" in _refused(
        suite, results, tmp_path, capsys, unknown
    )

    def other_manifest(data):
        data["manifest_sha256"] = "0" * 64

    assert "not on multicrane-bench tiny" in _refused(
        suite, results, tmp_path, capsys, other_manifest
    )


def test_page_ranks_verified_results_and_keeps_the_best(suite, results, tmp_path, capsys):
    kept = suite / RESULTS_DIR
    kept.mkdir(exist_ok=True)
    (kept / results.name).write_bytes(results.read_bytes())
    page = tmp_path / "board.md"
    try:
        assert main(["suite", "page", str(suite), "--out", str(page)]) == 0
        text = page.read_text()
        assert "## Track `tiny`" in text and "| `prioritized` | motion | 2/2 |" in text
        spans = {e["id"]: e["makespan"] for e in read_results(results)["instances"]}
        assert read_best(read_manifest(suite)) == spans
        assert json.loads((suite / BEST).read_text())["instances"]["small-01"]["results"] == (
            f"{RESULTS_DIR}/{results.name}"
        )
        data = read_results(results)
        data["instances"][0]["makespan"] -= 1
        write_results(kept / "zz-forged.json", data)
        assert main(["suite", "page", str(suite), "--out", str(page)]) == 1
        assert "zz-forged.json: small-01: the results say makespan" in capsys.readouterr().err
    finally:
        for path in kept.iterdir():
            path.unlink()


def test_bounds_command_keeps_each_bound_with_its_status(suite, capsys):
    from multicrane.suite.bounds import BOUNDS, read_bounds

    try:
        assert main(["suite", "bounds", str(suite), "--time-limit", "5"]) == 0
        bounds = read_bounds(read_manifest(suite))
        assert list(bounds) == list(TINY)
        for name, entry in bounds.items():
            assert entry["status"] in ("optimal", "feasible", "unknown"), name
            assert entry["workers"] == 1 and entry["time_limit"] == 5.0
        assert "small-01: bound" in capsys.readouterr().out
    finally:
        (suite / BOUNDS).unlink(missing_ok=True)
    assert main(["suite", "build", "v0"]) == 2
    assert "unknown suite version 'v0'" in capsys.readouterr().err
