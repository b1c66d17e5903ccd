"""Verify a results file: re-simulate every record and refuse any that is not what it claims.

``verify(results, manifest)`` checks that the results were made on this manifest (suite,
version and manifest checksum), then for each entry, in order, that: its instance is in the
suite; its record is intact (the record's own checksum) and well formed; the record was made
on the instance's scenario file (its SHA-256), with its crane count, reset seed and the
claiming mode (``auto = false``); its site-event schedule is the one the instance's event
level draws from that seed (none without events); re-simulating it reproduces every step's
events and its end (``multicrane.replay.record.resimulate``); and the entry's ``makespan``
and ``success`` are the re-simulated ones. The first failure is a ``SuiteError`` whose
message starts with the instance id; otherwise the verified entries are returned.
"""

from __future__ import annotations

import json
from typing import Any

from multicrane.replay import record_file
from multicrane.replay.record import EpisodeRecord, RecordError, resimulate
from multicrane.suite.manifest import Instance, Manifest, SuiteError
from multicrane.suite.play import make_env
from multicrane.suite.tracks import SUITE


def verify(results: dict[str, Any], manifest: Manifest) -> list[dict[str, Any]]:
    """The entries of ``results``, each re-simulated and checked (SuiteError at the first
    that fails, naming its instance)."""
    made_on = (results.get("suite"), results.get("version"), results.get("manifest_sha256"))
    if made_on != (SUITE, manifest.version, manifest.sha256):
        raise SuiteError(
            f"results made on {made_on[0]} {made_on[1]} (manifest sha256 {made_on[2]}), not on "
            f"{SUITE} {manifest.version} (manifest sha256 {manifest.sha256})"
        )
    seen: set[str] = set()
    for entry in results["instances"]:
        instance = _instance(entry, manifest, seen)
        try:
            verify_entry(entry, instance, manifest)
        except (RecordError, ValueError) as exc:
            message = str(exc)
            prefix = "" if message.startswith(f"{instance.id}:") else f"{instance.id}: "
            raise SuiteError(prefix + message) from None
    return results["instances"]


def _instance(entry: Any, manifest: Manifest, seen: set[str]) -> Instance:
    name = entry.get("id") if isinstance(entry, dict) else None
    instance = manifest.get(name) if isinstance(name, str) else None
    if instance is None:
        raise SuiteError(f"{name}: not an instance of {SUITE} {manifest.version}")
    if name in seen:
        raise SuiteError(f"{name}: appears twice in the results")
    seen.add(name)
    return instance


def verify_entry(entry: dict[str, Any], instance: Instance, manifest: Manifest) -> None:
    """Check one entry against its instance (see the module doc); SuiteError if it fails."""
    record = _record(entry, instance)
    settings = {
        "scenario sha256": (record.scenario_sha256, instance.sha256),
        "crane count": (record.n_cranes, instance.cranes),
        "reset seed": (record.seed, instance.seed),
        "auto": (record.auto, False),
    }
    for name, (got, want) in settings.items():
        if got != want:
            raise SuiteError(f"{instance.id}: the record's {name} is {got!r}, the instance's "
                             f"{want!r}")  # fmt: skip
    if record.schedule != _schedule(manifest, instance):
        raise SuiteError(f"{instance.id}: the record's site events are not those of event "
                         f"level {instance.events!r} from seed {instance.seed}")  # fmt: skip
    env, _, _ = resimulate(record, manifest.scenario(instance))
    done = bool(env.sim.done)
    makespan = int(env.sim.state.step_count) if done else None
    if (entry.get("makespan"), entry.get("success")) != (makespan, done):
        raise SuiteError(
            f"{instance.id}: the results say makespan {entry.get('makespan')!r} (success "
            f"{entry.get('success')!r}); the record re-simulates to {makespan!r} (success {done})"
        )


def _record(entry: dict[str, Any], instance: Instance) -> EpisodeRecord:
    data = entry.get("record")
    if not isinstance(data, dict):
        raise SuiteError(f"{instance.id}: no record")
    body = {k: v for k, v in data.items() if k != record_file.CHECKSUM}
    if data.get(record_file.CHECKSUM) != record_file.checksum(body):
        raise SuiteError(f"{instance.id}: the record was changed after it was written "
                         "(its checksum does not match its content)")  # fmt: skip
    return EpisodeRecord.from_dict(body, source=instance.id)


def _schedule(manifest: Manifest, instance: Instance) -> dict[str, Any]:
    """The schedule a record of the instance must hold, as stored (JSON types; {}: none)."""
    if instance.events == "none":
        return {}
    env = make_env(manifest, instance)
    env.reset(seed=instance.seed)
    return json.loads(json.dumps(env.sim.schedule.to_json()))
