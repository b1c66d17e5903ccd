"""The results files kept with v1: made on its manifest, best.json agrees; (long) they verify."""

from __future__ import annotations

import json

import pytest

from multicrane.suite.bounds import read_bounds
from multicrane.suite.manifest import read_manifest
from multicrane.suite.page import BEST, best_known, collect, results_files
from multicrane.suite.results import read_results


@pytest.fixture(scope="module")
def v1():
    return read_manifest("v1")


def test_kept_results_name_the_manifest_and_give_best_json(v1):
    paths = results_files(v1)
    assert paths, "no results kept for v1"
    collected = [{"path": p, "results": read_results(p)} for p in paths]
    for item in collected:
        assert item["results"]["manifest_sha256"] == v1.sha256, item["path"]
    shipped = json.loads((v1.folder / BEST).read_text())
    assert shipped["manifest_sha256"] == v1.sha256
    assert shipped["instances"] == best_known(collected, v1.folder)


def test_every_instance_has_a_bound_at_most_its_best_known(v1):
    bounds = read_bounds(v1)
    best = json.loads((v1.folder / BEST).read_text())["instances"]
    assert set(bounds) == {i.id for i in v1.instances}
    for name, entry in best.items():
        assert bounds[name]["bound"] <= entry["makespan"], name


@pytest.mark.long
def test_every_kept_results_file_verifies(v1):
    assert len(collect(v1, results_files(v1))) == len(results_files(v1))
