"""Build a suite version's files: every instance's scenario file and the manifest, byte for byte.

``build(version, folder)`` writes ``folder/TRACK/ID.toml`` (``to_toml`` of the generated
site) for every instance of ``multicrane.suite.tracks.instances(version)`` and
``folder/manifest.toml``; the same code writes the same bytes, so a shipped version is
checked by rebuilding it (``scenario_texts`` for a few tracks, without writing).
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from pathlib import Path

from multicrane.files import write_atomic
from multicrane.scenario.writer import to_toml
from multicrane.suite.manifest import MANIFEST, Instance, manifest_text
from multicrane.suite.tracks import SUITE, InstanceSpec, instances, sizes

HEADER = """{suite} {version}: frozen instances, written by `multicrane suite build {version}`
(multicrane.suite.build) from multicrane.scenario.generator with the fixed rule of
multicrane.suite.tracks. Do not edit: every file is pinned by its sha256 below, and results
name the version by this file's own sha256. docs/suite.md says how to use it."""


def scenario_texts(version: str, tracks: list[str] | None = None) -> dict[InstanceSpec, str]:
    """Each instance's scenario file text (of ``tracks`` only, when given)."""
    chosen = [i for i in instances(version) if tracks is None or i.track in tracks]
    return {spec: to_toml(spec.scenario()) for spec in chosen}


def build(version: str, folder: Path, log: Callable[[str], None] | None = None) -> Path:
    """Write every scenario file of ``version`` and its manifest under ``folder``; the
    manifest's path."""
    sizes(version)  # an unknown version is refused before anything is written
    rows = []
    for spec in instances(version):
        scenario = spec.scenario()
        text = to_toml(scenario)
        path = folder / spec.file
        path.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(path, text)
        sha256 = hashlib.sha256(text.encode("utf-8")).hexdigest()
        rows.append(Instance(
            spec.id, spec.file, spec.track, spec.family, scenario.n_components, spec.cranes,
            spec.seed, spec.events, spec.reach, sha256, spec.generator_seed, spec.params,
        ).row())  # fmt: skip
        if log:
            log(f"{spec.id}: {scenario.n_components} components, {spec.cranes} cranes")
    manifest = folder / MANIFEST
    write_atomic(manifest, manifest_text(version, HEADER.format(suite=SUITE, version=version),
                                         rows))  # fmt: skip
    return manifest
