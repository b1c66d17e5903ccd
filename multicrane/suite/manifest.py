"""The manifest of a suite version: every instance's file, checksum and settings, read and checked.

``scenarios/suite/VERSION/manifest.toml`` (``suite_dir(version)``) lists the instances as
``[[instance]]`` tables: ``id``, ``file`` (relative to the manifest's folder), ``track``,
``family``, ``components``, ``cranes``, ``seed`` (the reset seed), ``events`` (``"none"``,
``"low"`` or ``"high"``), ``reach``, ``sha256`` (of the file's bytes, which is the loaded
scenario's ``sha256``), and how the generator made it (``generator_seed``, ``params``).
``Manifest.sha256`` is the SHA-256 of the manifest file: results name the version they were
made on by it. ``manifest_text`` writes the file (deterministic; ``multicrane.suite.build``).
"""

from __future__ import annotations

import hashlib
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from multicrane.core.schema import Scenario
from multicrane.scenario.catalog import scenarios_dir
from multicrane.scenario.loader import load_scenario

MANIFEST = "manifest.toml"
FIELDS = ("id", "file", "track", "family", "components", "cranes", "seed", "events", "reach",
          "sha256", "generator_seed")  # fmt: skip


class SuiteError(ValueError):
    """A suite, manifest or results file that cannot be used; the message says why."""


@dataclass(frozen=True)
class Instance:
    """One instance as the manifest lists it."""

    id: str
    file: str
    track: str
    family: str
    components: int
    cranes: int
    seed: int
    events: str
    reach: bool
    sha256: str
    generator_seed: int
    params: tuple[tuple[str, Any], ...]

    def row(self) -> dict[str, Any]:
        """The manifest row (every field, ``params`` as a dict)."""
        return {**{key: getattr(self, key) for key in FIELDS}, "params": dict(self.params)}


@dataclass(frozen=True)
class Manifest:
    """A suite version: its folder, the manifest's checksum and its instances in file order."""

    version: str
    folder: Path
    sha256: str
    instances: tuple[Instance, ...]

    def get(self, instance_id: str) -> Instance | None:
        """The instance ``instance_id`` (None when the version has none of that id)."""
        return next((i for i in self.instances if i.id == instance_id), None)

    def track(self, name: str) -> list[Instance]:
        """The instances of track ``name`` (SuiteError naming the tracks if it has none)."""
        found = [i for i in self.instances if i.track == name]
        if not found:
            raise SuiteError(f"suite {self.version}: no track {name!r}; tracks: "
                             + ", ".join(self.tracks()))  # fmt: skip
        return found

    def tracks(self) -> list[str]:
        """The track names, in manifest order."""
        return list(dict.fromkeys(i.track for i in self.instances))

    def path(self, instance: Instance) -> Path:
        return self.folder / instance.file

    def scenario(self, instance: Instance) -> Scenario:
        """The instance's scenario, loaded from its file and checked against the manifest."""
        path = self.path(instance)
        problem = file_problem(path, instance.sha256)
        if problem:
            raise SuiteError(f"{instance.id}: {problem}")
        return load_scenario(path)


def suite_dir(version: str) -> Path:
    """The folder of a shipped suite version (``scenarios/suite/VERSION``)."""
    return scenarios_dir() / "suite" / version


def file_sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def file_problem(path: Path, sha256: str) -> str | None:
    """Why the file at ``path`` is not the one the manifest pins (None when it is)."""
    if not path.is_file():
        return f"{path}: no such file"
    got = file_sha256(path)
    if got != sha256:
        return f"{path}: sha256 {got} is not the manifest's {sha256}"
    return None


def read_manifest(where: str | Path) -> Manifest:
    """The manifest of a shipped version (``"v1"``) or of a folder holding ``manifest.toml``."""
    folder = Path(where)
    if not (folder / MANIFEST).is_file() and "/" not in str(where):
        folder = suite_dir(str(where))
    path = folder / MANIFEST
    if not path.is_file():
        raise SuiteError(f"{where}: no suite version of that name and no {MANIFEST} there")
    raw = path.read_bytes()
    try:
        data = tomllib.loads(raw.decode("utf-8"))
        rows = data["instance"]
        found = tuple(
            Instance(**{key: row[key] for key in FIELDS},
                     params=tuple(sorted(row["params"].items())))  # fmt: skip
            for row in rows
        )
        version = str(data["version"])
    except (KeyError, TypeError, ValueError, UnicodeDecodeError) as exc:
        raise SuiteError(f"{path}: not a suite manifest ({exc!r})") from None
    ids = [i.id for i in found]
    if len(set(ids)) != len(ids):
        raise SuiteError(f"{path}: an instance id appears twice")
    return Manifest(version, folder, hashlib.sha256(raw).hexdigest(), found)


def check_files(manifest: Manifest) -> list[str]:
    """Each instance whose file is missing or differs from its pinned checksum (empty: all
    match), as ``ID: problem``."""
    out = []
    for instance in manifest.instances:
        problem = file_problem(manifest.path(instance), instance.sha256)
        if problem:
            out.append(f"{instance.id}: {problem}")
    return out


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int | float):
        return repr(v)
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_value(x)}" for k, x in v.items()) + " }"
    return '"' + str(v).replace("\\", "\\\\").replace('"', '\\"') + '"'


def manifest_text(version: str, header: str, rows: list[dict[str, Any]]) -> str:
    """The manifest file of ``version``: a comment ``header``, then one table per row."""
    lines = [f"# {line}".rstrip() for line in header.splitlines()]
    lines += ["", f"version = {_value(version)}"]
    for row in rows:
        lines += ["", "[[instance]]"] + [f"{key} = {_value(row[key])}" for key in row]
    return "\n".join(lines) + "\n"
