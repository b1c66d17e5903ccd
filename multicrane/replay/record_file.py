"""Episode record files: checksummed JSON (gzip for .gz) written and read with strict types.

A file is the record's dict plus ``checksum``: the SHA-256 of the canonical JSON of the
rest (keys sorted, no spaces). Reading checks, in this order: the file can be read and
decompressed (at most ``MAX_RECORD_BYTES`` once decompressed), it is JSON, the checksum
matches (a file without one, written before checksums existed, is accepted with a
``RecordWarning``: its episode is still verified step by step when re-simulated), and every
field has its type (``Fields``). Each problem is one :class:`RecordError` whose message names
the file and the problem; nothing else escapes.
"""

from __future__ import annotations

import gzip
import hashlib
import io
import json
import math
import warnings
import zlib
from pathlib import Path
from typing import Any

from multicrane.envs.boundary import as_integer
from multicrane.files import write_atomic

MAX_RECORD_BYTES = 256 * 1024 * 1024  # decompressed; a record of 10^6 steps is ~30 MB
CHECKSUM = "checksum"


class RecordError(ValueError):
    """An episode record that cannot be used; the message says why."""


class RecordWarning(UserWarning):
    """A record file that loads but cannot be fully checked (no checksum: an old file)."""


def checksum(data: dict[str, Any]) -> str:
    """SHA-256 of the canonical JSON of ``data`` without its ``checksum`` entry."""
    body = {k: v for k, v in data.items() if k != CHECKSUM}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def write(path: str | Path, data: dict[str, Any]) -> Path:
    """Write ``data`` with its checksum, atomically (gzip when the name ends in ``.gz``)."""
    path = Path(path)
    text = json.dumps({**data, CHECKSUM: checksum(data)}, separators=(",", ":"))
    raw = text.encode("utf-8")
    write_atomic(path, gzip.compress(raw, mtime=0) if path.suffix == ".gz" else raw)
    return path


def read(path: str | Path) -> dict[str, Any]:
    """The checked dict of a record file; RecordError naming the file and the problem."""
    path = Path(path)
    try:
        raw = path.read_bytes()
        if path.suffix == ".gz":
            with gzip.GzipFile(fileobj=io.BytesIO(raw)) as f:
                raw = f.read(MAX_RECORD_BYTES + 1)
        if len(raw) > MAX_RECORD_BYTES:
            raise RecordError(f"{path}: larger than {MAX_RECORD_BYTES} bytes (MAX_RECORD_BYTES)")
        data = json.loads(raw.decode("utf-8"))
    except RecordError:
        raise
    except EOFError:
        raise RecordError(f"{path}: cannot read episode record: truncated gzip file") from None
    except zlib.error as exc:
        raise RecordError(f"{path}: cannot read episode record: corrupt gzip ({exc})") from None
    except RecursionError:
        raise RecordError(f"{path}: cannot read episode record: nested too deeply") from None
    except (OSError, ValueError) as exc:  # BadGzipFile, JSONDecodeError, UnicodeDecodeError
        raise RecordError(f"{path}: cannot read episode record: {exc}") from None
    if not isinstance(data, dict):
        raise RecordError(f"{path}: not an episode record (top level is not an object)")
    stored = data.pop(CHECKSUM, None)
    if stored is None:
        warnings.warn(
            f"{path}: episode record without a checksum (written before checksums existed); "
            "loaded unchecked",
            RecordWarning,
            stacklevel=3,
        )
    elif not isinstance(stored, str) or stored != checksum(data):
        raise RecordError(
            f"{path}: checksum mismatch: the file was changed after it was written "
            f"(stored {stored!r}, content hashes to {checksum(data)})"
        )
    return data


class Fields:
    """Reads a record dict's fields by name and type; errors name the source and field."""

    def __init__(self, source: str, data: dict[str, Any]):
        self.source = source
        self.data = data

    def fail(self, key: str, problem: str) -> RecordError:
        value = repr(self.data.get(key))
        value = value if len(value) <= 80 else value[:77] + "..."
        return RecordError(f"{self.source}: malformed episode record: {key} = {value}: {problem}")

    def _get(self, key: str, default: Any = ...) -> Any:
        if key not in self.data:
            if default is ...:
                raise RecordError(f"{self.source}: malformed episode record: {key} is missing")
            return default
        return self.data[key]

    def text(self, key: str, default: Any = ...) -> str:
        value = self._get(key, default)
        if not isinstance(value, str):
            raise self.fail(key, "must be a string")
        return value

    def flag(self, key: str) -> bool:
        value = self._get(key)
        if not isinstance(value, bool):
            raise self.fail(key, "must be true or false")
        return value

    def _int(self, key: str, value: Any, lo: int | None = None) -> int:
        try:
            n = as_integer(value, key)
        except TypeError:
            raise self.fail(key, f"must be an integer, not {value!r}") from None
        if lo is not None and n < lo:
            raise self.fail(key, f"must be at least {lo}")
        return n

    def integer(self, key: str, lo: int | None = None) -> int:
        return self._int(key, self._get(key), lo)

    def _rows(self, key: str, default: Any = ...) -> list:
        value = self._get(key, default)
        if not isinstance(value, list) or not all(isinstance(row, list) for row in value):
            raise self.fail(key, "must be a list of lists (one per step)")
        return value

    def actions(self, key: str, default: Any = ...) -> list[list[int]]:
        """Rows of non-negative integers (joint actions, or task decisions with ``[]``)."""
        return [[self._int(key, a, 0) for a in step] for step in self._rows(key, default)]

    def events(self, key: str) -> list[list[tuple[str, int, int]]]:
        out = []
        for step in self._rows(key):
            row = []
            for e in step:
                if not (isinstance(e, list) and len(e) == 3 and isinstance(e[0], str)):
                    raise self.fail(key, f"an event must be [type, crane, component], not {e!r}")
                row.append((e[0], self._int(key, e[1]), self._int(key, e[2])))
            out.append(row)
        return out

    def table(self, key: str, default: Any = ...) -> dict[str, Any]:
        value = self._get(key, default)
        if not isinstance(value, dict):
            raise self.fail(key, f"must be an object, got {type(value).__name__}")
        return value

    def metrics(self, key: str) -> dict[str, Any]:
        m = self._get(key)
        if not isinstance(m, dict):
            raise self.fail(key, "must be an object")
        out = dict(m)
        if "return" in m:
            r = m["return"]
            if isinstance(r, bool) or not isinstance(r, int | float) or not math.isfinite(r):
                raise self.fail(key, f"return must be a finite number, not {r!r}")
        if "steps" in m:
            out["steps"] = self._int(f"{key}.steps", m["steps"], 0)
        if "success" in m and not isinstance(m["success"], bool):
            raise self.fail(key, f"success must be true or false, not {m['success']!r}")
        if "final_status" in m:
            status = m["final_status"]
            if not isinstance(status, list):
                raise self.fail(key, "final_status must be a list of integers")
            out["final_status"] = [self._int(f"{key}.final_status", x) for x in status]
        return out
