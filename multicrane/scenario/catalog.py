"""The shipped scenarios: where they live, their names, and name-or-path resolution."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from multicrane.core.schema import ScenarioError

SCENARIO_SUFFIX = ".toml"


def scenarios_dir() -> Path:
    """The folder of shipped scenarios: inside the installed package, else the repository's."""
    packaged = resources.files("multicrane") / "scenarios"
    if packaged.is_dir():
        return Path(str(packaged))
    return Path(__file__).resolve().parents[2] / "scenarios"


def scenario_names() -> list[str]:
    """Names of the shipped scenarios, e.g. ``["e1s1", ..., "e4s4", "frame2-..."]``."""
    folder = scenarios_dir()
    return sorted(p.stem for p in folder.glob(f"*{SCENARIO_SUFFIX}"))


def resolve(scenario: str | Path) -> Path:
    """A shipped scenario name (``"e3s2"``, case-insensitive) or a path to a TOML file."""
    text = str(scenario)
    candidate = scenarios_dir() / f"{text.lower()}{SCENARIO_SUFFIX}"
    if "/" not in text and "\\" not in text and not text.endswith(SCENARIO_SUFFIX):
        if candidate.is_file():
            return candidate
        raise ScenarioError(
            f"unknown scenario {text!r}: not a shipped name ({', '.join(scenario_names())}) "
            "and not a path to a .toml file"
        )
    path = Path(text)
    if not path.is_file():
        raise ScenarioError(f"{path}: no such scenario file")
    return path
