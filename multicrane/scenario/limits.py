"""The scenario format's limits: file size, nesting, site volume, counts and number ranges.

Each limit is checked before anything is built from the value it bounds (the file's size
before parsing, the site's volume before any grid or obstacle cell list, the number of
components before they are read), and each failure is a
:class:`~multicrane.core.schema.ScenarioError` naming the file, the key, the value and the limit.
The limits are documented in ``scenarios/README.md`` and ``docs/reliability.md``.
"""

from __future__ import annotations

import math
import tomllib
from typing import Any

from multicrane.core.schema import Scenario, ScenarioError
from multicrane.scenario.toml_table import TomlTable

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


def check_component_count(source: str, data: dict[str, Any]) -> None:
    """The number of ``[[components]]`` against ``MAX_COMPONENTS`` (before reading them)."""
    comps = data.get("components")
    if isinstance(comps, list) and len(comps) > MAX_COMPONENTS:
        raise ScenarioError(
            f"{source}: components: {len(comps)} components; at most {MAX_COMPONENTS} "
            "(MAX_COMPONENTS: the occupancy grid is int16)"
        )


def check_numbers(s: Scenario) -> None:
    """Upper bounds of the rules' counts and the reward parameters' range (the loader has
    checked their types and lower bounds); errors name file, key, value and limit."""

    def fail(key: str, value: Any, problem: str) -> ScenarioError:
        return ScenarioError(f"{s.source}: {key} = {value!r}: {problem}")

    for key, value, hi, limit in (
        ("rules.cranes", s.cranes, MAX_CRANES, "MAX_CRANES"),
        ("rules.step_limit", s.step_limit, MAX_STEP_LIMIT, "MAX_STEP_LIMIT"),
        ("rules.assembly_steps", s.assembly_steps, MAX_ASSEMBLY_STEPS, "MAX_ASSEMBLY_STEPS"),
        ("reward.move_limit", s.reward.move_limit, MAX_STEP_LIMIT, "MAX_STEP_LIMIT"),
    ):
        if value > hi:
            raise fail(key, value, f"must be at most {hi} ({limit})")
    for name in ("completion", "over_limit_cost", "step_cost"):
        value = getattr(s.reward, name)
        if not math.isfinite(value):
            raise fail(f"reward.{name}", value, "must be a finite number (not nan or inf)")
        if value < 0:
            raise fail(f"reward.{name}", value, "must not be negative")
        if value > MAX_REWARD:
            raise fail(f"reward.{name}", value, f"must be at most {MAX_REWARD:g} (MAX_REWARD)")
