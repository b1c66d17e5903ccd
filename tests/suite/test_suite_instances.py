"""multicrane-bench v1's shipped instances: pinned by the manifest, loadable, rebuilt exactly."""

from __future__ import annotations

import pytest

from multicrane.scenario.loader import load_scenario
from multicrane.suite.build import scenario_texts
from multicrane.suite.manifest import (
    MANIFEST,
    SuiteError,
    check_files,
    manifest_text,
    read_manifest,
)
from multicrane.suite.tracks import instances, size_of, sizes, track_names

QUICK = ("small", "small-reach", "small-events")


@pytest.fixture(scope="module")
def v1():
    return read_manifest("v1")


def test_every_shipped_file_matches_its_checksum(v1):
    assert check_files(v1) == []
    assert v1.tracks() == list(track_names("v1"))
    assert [i.id for i in v1.instances] == [spec.id for spec in instances("v1")]


def test_a_changed_file_is_named(v1, tmp_path):
    rows = [i.row() for i in v1.instances[:2]]
    for row in rows:
        target = tmp_path / row["file"]
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes((v1.folder / row["file"]).read_bytes())
    (tmp_path / MANIFEST).write_text(manifest_text("test", "two instances", rows))
    (tmp_path / rows[1]["file"]).write_text((tmp_path / rows[1]["file"]).read_text() + "\n")
    copy = read_manifest(tmp_path)
    problems = check_files(copy)
    assert len(problems) == 1 and problems[0].startswith(f"{rows[1]['id']}: ")
    with pytest.raises(SuiteError, match=rows[1]["id"]):
        copy.scenario(copy.instances[1])
    assert copy.scenario(copy.instances[0]).sha256 == rows[0]["sha256"]


def test_tracks_keep_their_ranges(v1):
    by_size = {s.name: s for s in sizes("v1")}
    for i in v1.instances:
        size = by_size[size_of(i.track)]
        assert size.components[0] <= i.components <= size.components[1], i.id
        assert size.cranes[0] <= i.cranes <= size.cranes[1], i.id
        assert i.reach == i.track.endswith("-reach"), i.id
        assert (i.events != "none") == i.track.endswith("-events"), i.id
        assert dict(i.params)["random_start"] is False


@pytest.mark.parametrize("track", QUICK)
def test_small_tracks_load(v1, track):
    for instance in v1.track(track):
        scenario = load_scenario(v1.path(instance))
        assert scenario.n_components == instance.components, instance.id
        assert scenario.sha256 == instance.sha256, instance.id
        assert (scenario.crane_specs != ()) == instance.reach, instance.id


def test_the_small_track_rebuilds_bit_for_bit(v1):
    for spec, text in scenario_texts("v1", ["small"]).items():
        assert (v1.folder / spec.file).read_text() == text, spec.id


@pytest.mark.long
def test_every_track_loads_and_rebuilds_bit_for_bit(v1):
    texts = scenario_texts("v1")
    for spec, text in texts.items():
        assert (v1.folder / spec.file).read_text() == text, spec.id
        assert load_scenario(v1.folder / spec.file).sha256 == v1.get(spec.id).sha256


def test_unknown_version_and_track_are_refused(v1, tmp_path):
    with pytest.raises(SuiteError, match="no suite version"):
        read_manifest("v0")
    with pytest.raises(ValueError, match="unknown suite version"):
        instances("v0")
    with pytest.raises(SuiteError, match="tracks: small"):
        v1.track("tiny")
