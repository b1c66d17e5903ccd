"""A policy named with its options, ``NAME:KEY=VALUE,KEY=VALUE``: the one reader of that text.

``policies.registry`` builds policies from it (``lookahead:candidates=20``,
``prioritized:rank=nearest``); the layers below ``policies`` that only need to know which
policy a label names (a training run's teacher, a leaderboard entry) ask ``spec_name`` and
``spec_options``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any


class SpecError(ValueError):
    """A malformed option in a policy's name; the message names the text and the option."""


def split_spec(spec: str) -> tuple[str, dict[str, Any]]:
    """The name and options of ``NAME:KEY=VALUE,KEY=VALUE``: a value is read as an integer,
    a number, ``true``/``false``, or else kept as text; a name that is an existing path (a
    run directory with a colon in it) is taken whole."""
    text = str(spec)
    if ":" not in text or Path(text).exists():
        return text, {}
    name, _, rest = text.partition(":")
    options: dict[str, Any] = {}
    for part in rest.split(","):
        key, eq, value = (x.strip() for x in part.partition("="))
        if not eq or not key.isidentifier() or not value:
            raise SpecError(f"policy {text!r}: option {part!r} is not KEY=VALUE "
                            f"(e.g. lookahead:candidates=20)")  # fmt: skip
        if key in options:
            raise SpecError(f"policy {text!r}: option {key!r} is given twice")
        options[key] = _option_value(value)
    return name, options


def spec_name(spec: str) -> str:
    """The policy name of ``spec`` without its options (the text itself if malformed)."""
    try:
        return split_spec(spec)[0]
    except SpecError:
        return str(spec).partition(":")[0]


def spec_options(spec: str) -> dict[str, Any]:
    """The options of ``spec`` (none if malformed)."""
    try:
        return split_spec(spec)[1]
    except SpecError:
        return {}


def _option_value(text: str) -> Any:
    """An option's value from the command line: int, float, bool, else the text itself."""
    if text.lower() in ("true", "false"):
        return text.lower() == "true"
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text
