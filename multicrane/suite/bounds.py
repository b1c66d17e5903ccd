"""Each instance's proven makespan lower bound (CP-SAT), computed once and kept in bounds.json.

``compute_bounds(manifest, ids)`` runs ``multicrane.bounds.makespan.lower_bound`` on each
instance (its scenario, crane count, reset seed and event level; the size's time limit, one
worker by default) and merges the results into ``FOLDER/bounds.json``: per instance the bound,
the solver's status (``optimal``: the relaxation's optimum; ``feasible``/``unknown``: its best
proven bound when the time ran out), the relaxation's best schedule, the solver's seconds, the
time limit and ``events`` (the level whose schedule the bound knows, ``none`` without). An
instance's event schedule is drawn from its reset seed at reset and no action changes it, so
the bound knows it in hindsight: late deliveries and crane breakdowns (docs/bound.md).
The file names the manifest's checksum; ``read_bounds`` refuses one made for another manifest.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from multicrane.bounds.makespan import lower_bound
from multicrane.files import write_atomic
from multicrane.suite.manifest import Manifest, SuiteError
from multicrane.suite.tracks import size_of, sizes

BOUNDS = "bounds.json"


def read_bounds(manifest: Manifest) -> dict[str, dict[str, Any]]:
    """Instance id -> its bound entry (empty when no bounds were computed yet)."""
    path = manifest.folder / BOUNDS
    if not path.is_file():
        return {}
    data = json.loads(path.read_text())
    if data.get("manifest_sha256") != manifest.sha256:
        raise SuiteError(f"{path}: computed for another manifest (sha256 "
                         f"{data.get('manifest_sha256')}, not {manifest.sha256})")  # fmt: skip
    return data["instances"]


def time_limit(manifest: Manifest, track: str) -> float:
    """The CP-SAT seconds of the size ``track`` belongs to (60 for a version not built here)."""
    try:
        found = [s for s in sizes(manifest.version) if size_of(track) == s.name]
    except ValueError:
        found = []
    return found[0].bound_seconds if found else 60.0


def compute_bounds(
    manifest: Manifest,
    ids: list[str] | None = None,
    seconds: float | None = None,
    workers: int = 1,
    log: Callable[[str], None] | None = None,
) -> dict[str, dict[str, Any]]:
    """Bound the instances ``ids`` (default: all), merge them into bounds.json, return all."""
    known = read_bounds(manifest)
    for instance in manifest.instances:
        if ids is not None and instance.id not in ids:
            continue
        limit = seconds if seconds is not None else time_limit(manifest, instance.track)
        events = None if instance.events == "none" else instance.events
        r = lower_bound(manifest.scenario(instance), instance.cranes, instance.seed,
                        time_limit=limit, workers=workers, events=events)  # fmt: skip
        known[instance.id] = {
            "bound": r.value, "status": r.status, "relaxation_makespan": r.relaxation_makespan,
            "wall_s": round(r.wall_s, 1), "time_limit": limit, "workers": workers,
            "events": instance.events,
        }  # fmt: skip
        if log:
            log(f"{instance.id}: bound {r.value} ({r.status}, {r.wall_s:.1f} s)")
        _write(manifest, known)  # after each instance: a long run keeps what it found
    return known


def _write(manifest: Manifest, known: dict[str, dict[str, Any]]) -> None:
    order = [i.id for i in manifest.instances if i.id in known]
    data = {"version": manifest.version, "manifest_sha256": manifest.sha256,
            "instances": {key: known[key] for key in order}}  # fmt: skip
    write_atomic(manifest.folder / BOUNDS, json.dumps(data, indent=1) + "\n")
