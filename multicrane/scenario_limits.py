"""The scenario format's limits: file size, nesting, site volume, counts and number ranges.

Each limit is checked before anything is built from the value it bounds (the file's size
before parsing, the site's volume before any grid or obstacle cell list, the number of
components before they are read), and each failure is a
:class:`~multicrane.scenario.ScenarioError` naming the file, the key, the value and the limit.
The limits are documented in ``scenarios/README.md`` and ``docs/reliability.md``.
"""

from __future__ import annotations

import math
import tomllib
from typing import Any

from multicrane.scenario import ScenarioError
from multicrane.toml_table import TomlTable

MAX_FILE_BYTES = 4 * 1024 * 1024  # a scenario file is at most 4 MiB
MAX_DEPTH = 16  # tables and arrays nested at most this deep (the shipped files use 5)
MAX_SITE_CELLS = 262_144  # X * Y * height (= 64 x 64 x 64); the environment needs ~300 B/cell
MAX_COMPONENTS = 32_766  # occupancy is int16 and holds component index + 1 (<= 32767)
MAX_CRANES = 64
MAX_STEP_LIMIT = 10_000_000
MAX_ASSEMBLY_STEPS = 10_000
MAX_REWARD = 1e6  # every reward parameter's magnitude


def parse_toml(data: bytes, source: str) -> dict[str, Any]:
    """``tomllib`` on at most ``MAX_FILE_BYTES`` of UTF-8, nested at most ``MAX_DEPTH`` deep."""
    if len(data) > MAX_FILE_BYTES:
        raise ScenarioError(
            f"{source}: the file has {len(data)} bytes; a scenario file may have at most "
            f"{MAX_FILE_BYTES} (MAX_FILE_BYTES)"
        )
    text = data.decode("utf-8")  # UnicodeError: the caller's message
    try:
        parsed = tomllib.loads(text)
    except RecursionError:
        raise ScenarioError(
            f"{source}: tables or arrays nested too deeply to read (limit {MAX_DEPTH} levels)"
        ) from None
    where = _too_deep(parsed)
    if where is not None:
        raise ScenarioError(
            f"{source}: {where}: tables or arrays nested more than {MAX_DEPTH} levels deep "
            "(MAX_DEPTH)"
        )
    return parsed


def _too_deep(data: Any) -> str | None:
    """The key path of a value nested deeper than ``MAX_DEPTH``, or None (no recursion)."""
    stack: list[tuple[Any, str, int]] = [(data, "", 0)]
    while stack:
        value, path, depth = stack.pop()
        if depth > MAX_DEPTH:
            return path or "top level"
        if isinstance(value, dict):
            stack.extend(
                (v, f"{path}.{k}" if path else str(k), depth + 1) for k, v in value.items()
            )
        elif isinstance(value, list):
            stack.extend((v, f"{path}[{i}]", depth + 1) for i, v in enumerate(value))
    return None


def check_site_volume(site: TomlTable, size: tuple[int, ...]) -> None:
    """The site's cell count against ``MAX_SITE_CELLS`` (before any grid is allocated)."""
    cells = math.prod(size)
    if cells > MAX_SITE_CELLS:
        raise site.fail(
            "size",
            list(size),
            f"{cells} cells; a site may have at most {MAX_SITE_CELLS} (MAX_SITE_CELLS, e.g. "
            "64 x 64 x 64): larger sites would need gigabytes",
        )


def check_component_count(top: TomlTable, n: int) -> None:
    """The number of ``[[components]]`` against ``MAX_COMPONENTS`` (before reading them)."""
    if n > MAX_COMPONENTS:
        raise top.fail(
            "components",
            f"<{n} tables>",
            f"at most {MAX_COMPONENTS} components (MAX_COMPONENTS: the occupancy grid is int16)",
        )


def check_int(table: TomlTable, key: str, value: int, lo: int, hi: int, limit: str) -> None:
    """``lo <= value <= hi``, else an error naming the key, the value and the limit."""
    if value < lo:
        raise table.fail(
            key, value, "must not be negative" if lo == 0 else f"must be at least {lo}"
        )
    if value > hi:
        raise table.fail(key, value, f"must be at most {hi} ({limit})")


def check_reward(table: TomlTable, values: dict[str, float]) -> None:
    """Reward parameters: finite, not negative, at most ``MAX_REWARD``."""
    for key, value in values.items():
        if not math.isfinite(value):
            raise table.fail(key, value, "must be a finite number (not nan or inf)")
        if value < 0:
            raise table.fail(key, value, "must not be negative")
        if value > MAX_REWARD:
            raise table.fail(key, value, f"must be at most {MAX_REWARD:g} (MAX_REWARD)")
