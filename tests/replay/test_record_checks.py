"""Episode records that are not what they claim (issue 20): checksums, end metrics, files that
cannot be read, and fields of the wrong type.

Before the fix a tampered record replayed with a fake summary, re-simulation missed a flipped
success flag, a corrupt gzip file gave a bare ``EOFError``/``zlib.error`` and ``int()`` turned a
recorded action 2.7 into 2.
"""

from __future__ import annotations

import gzip
import json
import warnings

import pytest

import multicrane
from multicrane.cli import main
from multicrane.replay.record import (
    EpisodeRecord,
    RecordError,
    RecordMismatchError,
    RecordWarning,
    record_episode,
    resimulate,
    resimulate_steps,
)
from policies.random_policy import RandomPolicy


@pytest.fixture(scope="module")
def record() -> EpisodeRecord:
    env = multicrane.parallel_env("e2s2", n_cranes=2, max_steps=40)
    return record_episode(env, RandomPolicy(5), seed=5, policy_name="random")


def _copy(rec: EpisodeRecord) -> EpisodeRecord:
    return EpisodeRecord.from_dict(json.loads(json.dumps(rec.to_dict())))


# -- end metrics -----------------------------------------------------------------------------

END_EDITS = [
    # (field, new value, the message's fragment)
    ("return", 123.0, "return: recorded 123, re-simulated"),
    ("steps", 7, "steps: recorded 7, re-simulated 40"),
    ("success", True, "success: recorded True, re-simulated False"),
    ("final_status", [3, 3, 3], "final_status: recorded [3, 3, 3], re-simulated"),
]


@pytest.mark.parametrize(("field", "value", "fragment"), END_EDITS)
def test_tampered_end_metrics_are_named(record, field, value, fragment):
    bad = _copy(record)
    bad.metrics[field] = value
    with pytest.raises(RecordMismatchError) as info:
        resimulate(bad)
    assert fragment in str(info.value)
    # The step-by-step re-simulation (what `multicrane replay` and the viewer use) too.
    with pytest.raises(RecordMismatchError, match=field):
        for _ in resimulate_steps(bad):
            pass


def test_a_record_cut_short_is_refused(record):
    bad = _copy(record)
    del bad.actions[-5:], bad.events[-5:]
    with pytest.raises(RecordMismatchError, match="the episode goes on"):
        resimulate(bad)


# -- checksum ----------------------------------------------------------------------------------


def test_checksum_round_trip_and_tamper(record, tmp_path):
    path = record.save(tmp_path / "r.json")
    assert EpisodeRecord.load(path) == record
    data = json.loads(path.read_text())
    assert len(data["checksum"]) == 64
    data["metrics"]["success"] = True  # edited by hand, checksum left as it was
    path.write_text(json.dumps(data))
    with pytest.raises(RecordError, match=r"r\.json: checksum mismatch"):
        EpisodeRecord.load(path)


def test_old_record_without_checksum_loads_with_a_warning(record, tmp_path):
    path = tmp_path / "old.json"
    path.write_text(json.dumps(record.to_dict()))
    with pytest.warns(RecordWarning, match="without a checksum"):
        assert EpisodeRecord.load(path) == record


# -- unreadable files -------------------------------------------------------------------------


def _corruptions(good: bytes) -> dict[str, bytes]:
    middle = len(good) // 2
    return {
        "truncated": good[: len(good) // 3],
        "flipped": good[:middle] + bytes([good[middle] ^ 0xFF]) + good[middle + 1 :],
        "garbage": b"not gzip at all",
        "empty": b"",
        "bad-json": gzip.compress(b'{"format": 1, "scenario": '),
        "not-utf8": gzip.compress(b"\xff\xfe{}"),
        "deep": gzip.compress(b"[" * 100000 + b"]" * 100000),
        "list": gzip.compress(b"[1, 2]"),
    }


@pytest.mark.parametrize("case", list(_corruptions(b"x" * 10)))
def test_unreadable_gzip_record_is_one_record_error(record, tmp_path, case, capsys):
    good = record.save(tmp_path / "good.json.gz").read_bytes()
    path = tmp_path / f"{case}.json.gz"
    path.write_bytes(_corruptions(good)[case])
    with pytest.raises(RecordError) as info:
        EpisodeRecord.load(path)
    assert str(path) in str(info.value)
    # The command: one line on stderr naming the file, exit status 1.
    assert main(["replay", "replay", str(path), "--rrd", str(tmp_path / "x.rrd")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(path) in err[0], err


FIELD_EDITS = [
    ("seed", 2.7),
    ("seed", "3"),
    ("n_cranes", True),
    ("n_cranes", 0),
    ("auto", "no"),
    ("max_steps", None),
    ("actions", [[2.7, 6]]),
    ("actions", [[True, 6]]),
    ("actions", "66"),
    ("events", [[["MOVED", 0.5, 1]]]),
    ("events", [[["MOVED", 0]]]),
    ("metrics", {"return": float("nan")}),
    ("metrics", {"steps": 1.5}),
    ("metrics", {"success": 1}),
    ("metrics", []),
    ("scenario", 3),
]


@pytest.mark.parametrize(("field", "value"), FIELD_EDITS, ids=repr)
def test_record_fields_are_not_coerced(record, field, value):
    data = record.to_dict()
    data[field] = value
    with pytest.raises(RecordError, match=f"malformed episode record: {field}"):
        EpisodeRecord.from_dict(data, source="case.json")


def test_tampered_record_replay_command_names_the_field(record, tmp_path, capsys):
    pytest.importorskip("rerun")
    bad = _copy(record)
    bad.metrics["success"] = True
    path = bad.save(tmp_path / "bad.json.gz")  # a valid checksum: only re-simulation tells
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert main(["replay", "replay", str(path), "--rrd", str(tmp_path / "x.rrd")]) == 2
    err = capsys.readouterr().err
    assert "success: recorded True, re-simulated False" in err
