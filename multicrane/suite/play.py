"""Play a policy on every instance of a track and keep each episode's record: a results dict.

``play_track(manifest, track, make_policy, label, decisions)`` plays, for each instance of the
track, the episode ``reset(seed)`` starts on its scenario with its crane count and event level
(claiming mode, ``auto=False``), with ``make_policy(env, seed)`` (the caller's: the command
line resolves planner names and training runs, ``multicrane`` never imports ``policies``) at
the decision level ``decisions`` (``motion`` or ``task``; a task-level episode is recorded by
its physical steps, so every record re-simulates in the motion mode). The results dict
(``multicrane.suite.results`` reads and writes it) names the suite version, the manifest's
checksum, the track, the policy and its decision level, and per instance: ``id``,
``makespan`` (``None`` when the building was not completed), ``success``, ``seconds`` (wall
time of the episode, policy included), ``bound`` and its ``bound_status`` (from
bounds.json, when computed), ``best_known`` (the best verified makespan when evaluated) and
``record``: the episode record's dict with its ``checksum`` (``multicrane.replay.record_file``).
A learned policy's results also carry ``training`` (``training_block``): the run directory's
name and its ``config.json``, so an entry says how its policy was trained whatever it is named.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.replay import record_file
from multicrane.replay.record import EpisodeRecord, record_episode
from multicrane.suite.bounds import read_bounds
from multicrane.suite.manifest import Instance, Manifest
from multicrane.suite.tracks import SUITE

RESULTS_FORMAT = 1
MakePolicy = Callable[[Any, int], Callable]


def make_env(manifest: Manifest, instance: Instance, decisions: str = "motion") -> MultiCraneEnv:
    """The instance's environment: its checked scenario, crane count and event level."""
    return MultiCraneEnv(
        manifest.scenario(instance), n_cranes=instance.cranes, decisions=decisions,
        events=None if instance.events == "none" else instance.events,
    )  # fmt: skip


def play_instance(manifest: Manifest, instance: Instance, make_policy: MakePolicy, label: str,
                  decisions: str = "motion") -> tuple[EpisodeRecord, float]:  # fmt: skip
    """The record of the instance's episode played by the policy, and its wall seconds."""
    env = make_env(manifest, instance, decisions)
    began = time.perf_counter()
    record = record_episode(env, make_policy(env, instance.seed), instance.seed, label)
    seconds = time.perf_counter() - began
    record.scenario_source = _source(manifest.path(instance))
    return record, seconds


def _source(path: Path) -> str:
    """The scenario file as a record names it: relative to here when below it (a results
    file made from the repository root names ``scenarios/suite/...``), else absolute."""
    relative = os.path.relpath(path.resolve())
    return str(path.resolve()) if relative.startswith("..") else relative


def makespan_of(record: EpisodeRecord) -> int | None:
    """The recorded makespan: the steps to complete the building (None: not completed)."""
    return int(record.metrics["steps"]) if record.metrics.get("success") else None


def play_track(
    manifest: Manifest,
    track: str,
    make_policy: MakePolicy,
    label: str,
    decisions: str = "motion",
    best: dict[str, int] | None = None,
    log: Callable[[dict[str, Any]], None] | None = None,
    training: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The results dict of the policy on every instance of ``track`` (see the module doc);
    ``best``: the best-known makespans to store beside each; ``log`` sees each entry;
    ``training``: a learned policy's ``training_block``."""
    bounds = read_bounds(manifest)
    entries = []
    for instance in manifest.track(track):
        record, seconds = play_instance(manifest, instance, make_policy, label, decisions)
        entries.append(results_entry(instance, record, seconds, bounds, best))
        if log:
            log(entries[-1])
    return results_dict(manifest, track, label, decisions, entries, training)


def results_entry(instance: Instance, record: EpisodeRecord, seconds: float,
                  bounds: dict[str, dict[str, Any]], best: dict[str, int] | None
                  ) -> dict[str, Any]:  # fmt: skip
    """One instance's entry of a results dict: its makespan, bound, best known and record."""
    data = record.to_dict()
    bound = bounds.get(instance.id, {})
    return {
        "id": instance.id, "makespan": makespan_of(record),
        "success": bool(record.metrics["success"]), "seconds": round(seconds, 2),
        "bound": bound.get("bound"), "bound_status": bound.get("status"),
        "best_known": (best or {}).get(instance.id),
        "record": {**data, record_file.CHECKSUM: record_file.checksum(data)},
    }  # fmt: skip


def results_dict(manifest: Manifest, track: str, label: str, decisions: str,
                 entries: list[dict[str, Any]], training: dict[str, Any] | None = None
                 ) -> dict[str, Any]:  # fmt: skip
    """A results dict (see the module doc) of the entries of one track."""
    results = {
        "format": RESULTS_FORMAT, "suite": SUITE, "version": manifest.version,
        "manifest_sha256": manifest.sha256, "track": track, "policy": label,
        "decisions": decisions,
    }  # fmt: skip
    if training is not None:
        results["training"] = training
    return {**results, "instances": entries}


def training_block(run_dir: str | Path, config: dict[str, Any]) -> dict[str, Any]:
    """What a learned policy's results say of its training: the run directory's name and its
    configuration (``config.json``: everything ``multicrane train`` was told); ``run_dir``
    may name the run's ``model.zip``."""
    run_dir = Path(run_dir)
    return {"run": (run_dir.parent if run_dir.suffix == ".zip" else run_dir).name,
            "config": config}  # fmt: skip
