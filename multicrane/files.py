"""Safe file handling: atomic writes (a reader or a crash never sees half a file), and free
names for setting a corrupt file aside."""

from __future__ import annotations

import datetime
import json
import os
from pathlib import Path
from typing import Any


def _written_beside(path: Path, data: str | bytes) -> Path:
    """``data`` in a temporary file beside ``path``, named with this process's id (so two
    writers never share it)."""
    tmp = path.with_name(f"{path.name}.tmp-{os.getpid()}")
    if isinstance(data, bytes):
        tmp.write_bytes(data)
    else:
        tmp.write_text(data)
    return tmp


def write_atomic(path: str | Path, data: str | bytes) -> None:
    """Write ``data`` to a temporary file beside ``path``, then rename it over ``path``."""
    _written_beside(Path(path), data).replace(path)


def write_new_atomic(path: str | Path, data: bytes) -> bool:
    """Write ``data`` to ``path`` only if no file is there, whole or not at all: a temporary
    file beside it is linked to the name, which fails when another writer got there first.
    True when this call wrote the file."""
    tmp = _written_beside(Path(path), data)
    try:
        os.link(tmp, path)
    except FileExistsError:
        return False
    finally:
        tmp.unlink()
    return True


def write_json_atomic(path: str | Path, obj: Any, indent: int = 1) -> None:
    """``obj`` as JSON (sorted keys are the caller's choice), ending with a newline."""
    write_atomic(path, json.dumps(obj, indent=indent) + "\n")


def aside_path(path: str | Path) -> Path:
    """A free name beside ``path`` to move a corrupt file or folder to (``NAME.corrupt-STAMP``,
    with ``-2``, ``-3`` ... when that is taken), so nothing is deleted."""
    path = Path(path)
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    candidate = path.with_name(f"{path.name}.corrupt-{stamp}")
    n = 1
    while candidate.exists():
        n += 1
        candidate = path.with_name(f"{path.name}.corrupt-{stamp}-{n}")
    return candidate
