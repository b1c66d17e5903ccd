"""A strict TOML table reader: every key read by name and type, unknown keys refused.

Each problem becomes a :class:`~multicrane.core.schema.ScenarioError` whose message names the
file, the key (with its path, e.g. ``components[2].target``) and the value.
"""

from __future__ import annotations

import difflib
from typing import Any

from multicrane.core.schema import ScenarioError


class TomlTable:
    """A TOML table read key by key; unknown keys are errors, every error names the key."""

    def __init__(self, source: str, path: str, data: Any):
        self.source = source
        self.path = path
        if not isinstance(data, dict):
            raise ScenarioError(f"{source}: {path or 'top level'} must be a table, got {data!r}")
        self.data = data
        self.used: set[str] = set()

    def key(self, name: str) -> str:
        return f"{self.path}.{name}" if self.path else name

    def fail(self, name: str, value: Any, problem: str) -> ScenarioError:
        if name not in self.data and value is None:
            return ScenarioError(f"{self.source}: {self.key(name)}: {problem}")
        return ScenarioError(f"{self.source}: {self.key(name)} = {value!r}: {problem}")

    def refuse(self, name: str, problem: str) -> ScenarioError:
        """``fail`` with the value the table gives ``name`` (None where it gives none)."""
        return self.fail(name, self.data.get(name), problem)

    def missing(self, name: str, what: str = "required key is missing") -> ScenarioError:
        """A required key is absent; name a present key that looks like a misspelling of it."""
        close = difflib.get_close_matches(name, [str(k) for k in self.data], n=1, cutoff=0.6)
        hint = ""
        if close and close[0] not in self.used:
            value = self.data[close[0]]
            shown = (
                f"[{self.key(close[0])}]"
                if isinstance(value, dict)
                else (f"{self.key(close[0])} = {value!r}")
            )
            hint = f"; unknown key {shown} looks like a misspelling of it"
        where = f"[{self.key(name)}]" if "table" in what else self.key(name)
        return ScenarioError(f"{self.source}: {where}: {what}{hint}")

    def has(self, name: str) -> bool:
        return name in self.data

    def get(self, name: str, kind: type | tuple[type, ...], default: Any = ...) -> Any:
        self.used.add(name)
        if name not in self.data:
            if default is ...:
                raise self.missing(name)
            return default
        value = self.data[name]
        kinds = kind if isinstance(kind, tuple) else (kind,)
        # TOML booleans are not integers here, and integers are accepted where floats are.
        ok = isinstance(value, kinds) and not (isinstance(value, bool) and bool not in kinds)
        if not ok and float in kinds and isinstance(value, int) and not isinstance(value, bool):
            value, ok = float(value), True
        if not ok:
            names = " or ".join(k.__name__ for k in kinds)
            raise self.fail(name, value, f"must be {_article(names)}")
        return value

    def ints(self, name: str, n: int | None = None, default: Any = ...) -> tuple[int, ...]:
        value = self.get(name, list, default)
        if value is default and default is not ...:
            return value
        return self.check_ints(name, value, n)

    def check_ints(self, name: str, value: Any, n: int | None) -> tuple[int, ...]:
        if not isinstance(value, list) or not all(
            isinstance(v, int) and not isinstance(v, bool) for v in value
        ):
            raise self.fail(name, value, "must be a list of integers")
        if n is not None and len(value) != n:
            raise self.fail(name, value, f"must have {n} integers")
        return tuple(value)

    def table(self, name: str, required: bool = True) -> TomlTable | None:
        self.used.add(name)
        if name not in self.data:
            if required:
                raise self.missing(name, "required table is missing")
            return None
        return TomlTable(self.source, self.key(name), self.data[name])

    def tables(self, name: str) -> list[TomlTable]:
        value = self.get(name, list)
        return [TomlTable(self.source, f"{self.key(name)}[{i}]", v) for i, v in enumerate(value)]

    def finish(self) -> None:
        unknown = sorted(set(self.data) - self.used)
        if unknown:
            name = unknown[0]
            raise self.fail(name, self.data[name], "unknown key (check the spelling)")


def _article(names: str) -> str:
    return ("an " if names[0] in "aeiou" else "a ") + names
