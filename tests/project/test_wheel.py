"""The shipped scenario files travel with a wheel and are found when it is installed.

A wheel is built from the repository with pip (the build backend is hatchling; pip fetches it
into an isolated build environment unless it is installed already), inspected, installed into
a bare target folder, and imported from there by a fresh interpreter whose working directory
is outside the repository, so the repository's own ``scenarios/`` folder cannot be found.
"""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SCENARIO_FILES = sorted(p.name for p in (REPO / "scenarios").glob("*.toml"))
POLICY_FILES = sorted(p.name for p in (REPO / "policies").glob("*.py"))
PACKAGE_FILES = sorted(p.name for p in (REPO / "multicrane").glob("*.py"))


def _run(args, **kwargs):
    result = subprocess.run(args, capture_output=True, text=True, timeout=300, **kwargs)
    assert result.returncode == 0, (
        f"{' '.join(map(str, args))} failed ({result.returncode}):\n"
        f"{result.stdout[-3000:]}\n{result.stderr[-3000:]}"
    )
    return result


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("wheel")
    args = [sys.executable, "-m", "pip", "wheel", str(REPO), "--no-deps", "-w", str(out)]
    if importlib.util.find_spec("hatchling") is not None:
        args.append("--no-build-isolation")  # the backend is here: no download needed
    _run(args, cwd=out)
    wheels = sorted(out.glob("multicrane-*.whl"))
    assert len(wheels) == 1, list(out.iterdir())
    return wheels[0]


def test_wheel_contents(wheel):
    names = set(zipfile.ZipFile(wheel).namelist())
    assert SCENARIO_FILES, "no scenario files in the repository"
    # the 16 paper configurations, frame2-3c, hall-4c, towers-3c, precast-frame, precast-house
    assert len(SCENARIO_FILES) == 21
    for name in SCENARIO_FILES:
        assert f"multicrane/scenarios/{name}" in names, f"{name} is missing from the wheel"
    for name in PACKAGE_FILES:
        assert f"multicrane/{name}" in names
    for name in POLICY_FILES:
        assert f"policies/{name}" in names
    # The scenario files are data inside the package, not a top-level folder.
    assert not any(n.startswith("scenarios/") for n in names)
    # The wheel carries the files byte for byte.
    with zipfile.ZipFile(wheel) as z:
        for name in SCENARIO_FILES:
            packed = z.read(f"multicrane/scenarios/{name}")
            assert packed == (REPO / "scenarios" / name).read_bytes(), name


def test_installed_wheel_finds_its_scenarios(wheel, tmp_path):
    target = tmp_path / "site"
    _run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "--target", str(target), wheel],
        cwd=tmp_path,
    )
    workdir = tmp_path / "elsewhere"
    workdir.mkdir()
    code = (
        "import json, multicrane, multicrane.scenario.catalog as s\n"
        "env = multicrane.parallel_env('e2s2')\n"
        "obs, _ = env.reset(seed=0)\n"
        "print(json.dumps({'file': multicrane.__file__, 'names': multicrane.scenario_names(),"
        " 'dir': str(s.scenarios_dir()), 'source': env.scenario.source,"
        " 'agents': env.agents}))\n"
    )
    environ = dict(os.environ)
    environ["PYTHONPATH"] = str(target)
    environ.pop("PYTHONHOME", None)
    result = _run([sys.executable, "-c", code], cwd=workdir, env=environ)
    report = json.loads(result.stdout.strip().splitlines()[-1])
    target = target.resolve()
    assert Path(report["file"]).resolve().is_relative_to(target), report["file"]
    assert report["names"] == sorted(Path(n).stem for n in SCENARIO_FILES)
    assert len(report["names"]) == 21
    scenarios_dir = Path(report["dir"]).resolve()
    assert scenarios_dir == target / "multicrane" / "scenarios"
    assert Path(report["source"]).resolve().is_relative_to(scenarios_dir)
    assert report["agents"] == ["crane_0"]
