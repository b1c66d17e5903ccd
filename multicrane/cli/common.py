"""What the subcommands share: the environment options, building that environment, errors."""

from __future__ import annotations

import argparse
import ast
import sys

from multicrane.envs.decision_modes import DECISION_MODES, DEFAULT_DECISIONS

# Importable module (first dotted part) -> the extra of pyproject.toml that installs it.
EXTRAS = {
    "torch": "train",
    "stable_baselines3": "train",
    "sb3_contrib": "train",
    "supersuit": "train",
    "tensorboard": "train",
    "rerun": "replay",
    "matplotlib": "bench",
    "ray": "ray",
    "ifcopenshell": "ifc",
}


def missing_extra(exc: BaseException | None) -> str | None:
    """The extra that would install the module ``exc`` (or the import error it was raised
    from) failed to import, if it is one of ours."""
    while exc is not None:
        name = (getattr(exc, "name", None) or "").split(".")[0]
        if name in EXTRAS:
            return EXTRAS[name]
        exc = exc.__cause__ or exc.__context__
    return None


# The spellings of TOML, JSON and YAML for the Python literals True, False and None.
_WORDS = {"true": True, "false": False, "none": None, "null": None}


def set_value(text: str):
    """A ``--set`` value: a Python literal (number, boolean, list, dict; ``true``, ``false``
    and ``null`` in any case too), else the string itself."""
    if text.lower() in _WORDS:
        return _WORDS[text.lower()]
    try:
        return ast.literal_eval(text)
    except (ValueError, SyntaxError):
        return text


def set_overrides(items: list[str]) -> dict:
    """The ``--set KEY=VALUE`` options as a dict; ValueError names an item without ``=``."""
    overrides = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ValueError(f"--set {item!r}: expected KEY=VALUE")
        overrides[key.strip()] = set_value(value.strip())
    return overrides


def needs_extra(command: str, extra: str) -> int:
    """Say which extra a command needs (one line on stderr) and return exit status 2."""
    print(
        f"multicrane {command} needs the '{extra}' extra: pip install 'multicrane[{extra}]'",
        file=sys.stderr,
    )
    return 2


def error(message: object, status: int = 2) -> int:
    """Print ``error: message`` on stderr and return ``status``."""
    print(f"error: {message}", file=sys.stderr)
    return status


def formatter() -> dict:
    """Keyword arguments for a subparser that shows its description as written."""
    return {"formatter_class": argparse.RawDescriptionHelpFormatter}


def add_environment_args(p: argparse.ArgumentParser, required: bool = True) -> None:
    """``--paper CONFIG`` or ``--scenario NAME`` (one of them), ``--cranes``, ``--auto``,
    ``--decisions``, ``--events``."""
    where = p.add_mutually_exclusive_group(required=required)
    where.add_argument("--paper", metavar="CONFIG", help="single-agent benchmark: E1S1 .. E4S4")
    where.add_argument("--scenario", help="multi-agent: shipped scenario name or .toml path")
    p.add_argument("--cranes", type=int, default=None, help="cranes (default: scenario's)")
    p.add_argument("--auto", action="store_true", help="multi-agent automatic mode")
    p.add_argument("--decisions", choices=tuple(DECISION_MODES), default=DEFAULT_DECISIONS,
                   help="multi-agent decision level: motion (every move) or task (which "
                   "component to which target)")  # fmt: skip
    add_events_arg(p)


EVENT_LEVELS = ("none", "low", "high")  # multicrane.sim.events.LEVELS (not imported: startup time)


def add_events_arg(p: argparse.ArgumentParser) -> None:
    """``--events LEVEL``: the site events of the multi-agent environment."""
    p.add_argument("--events", choices=EVENT_LEVELS, default=None,
                   help="multi-agent: site events (late deliveries, breakdowns, closed zones; "
                   "docs/uncertainty.md): none, low or high (default: the scenario's own "
                   "[events] table, or a run directory policy's training level)")  # fmt: skip


def run_events(level: str | None, factories) -> str | None:
    """The events level to play: ``level`` if given, else the one the training runs among
    ``factories`` (``policies.factory``) were trained with (None if none set one)."""
    if level is not None:
        return level
    found = {getattr(f.config, "events", None) for f in factories if f.config is not None}
    found.discard(None)
    if len(found) > 1:
        raise ValueError(
            "the run directories were trained with different --events "
            f"({', '.join(sorted(found))}): give --events LEVEL"
        )
    return found.pop() if found else None


def add_decisions_arg(p: argparse.ArgumentParser) -> None:
    """``--decisions LEVEL`` for commands that play run directories: default, their own."""
    p.add_argument("--decisions", choices=tuple(DECISION_MODES), default=None,
                   help="multi-agent decision level: motion (every move) or task (which "
                   "component to which target); default: a run directory policy's training "
                   "level, else motion")  # fmt: skip


def trained_decisions(factory) -> str:
    """The decision mode a policy (``policies.factory``) plays at: its training run's, else
    the default (``"motion"``)."""
    return getattr(factory.config, "decisions", DEFAULT_DECISIONS)


def run_decisions(level: str | None, factories) -> str:
    """The decision level to play: ``level`` if given, else the one the training runs among
    ``factories`` were trained at (a set policy reads task-level observations only), else
    ``"motion"``."""
    if level is not None:
        return level
    found = {trained_decisions(f) for f in factories if f.config is not None}
    if len(found) > 1:
        raise ValueError(
            "the run directories were trained at different decision levels "
            f"({', '.join(sorted(found))}): give --decisions LEVEL"
        )
    return found.pop() if found else DEFAULT_DECISIONS


def make_env(paper: str | None, scenario=None, cranes=None, auto=False, **options):
    """The paper-mode Gymnasium env for ``paper`` (with the blocked-move mask, which changes no
    dynamics: masked models need it, the others ignore it), else the multi-agent env."""
    import multicrane

    if paper:
        if options.get("decisions", DEFAULT_DECISIONS) != DEFAULT_DECISIONS:
            raise ValueError(
                f"--decisions {options['decisions']} is a multi-agent option (use --scenario)"
            )
        if options.get("events") is not None:
            raise ValueError(
                f"--events {options['events']} is a multi-agent option (use --scenario)"
            )
        return multicrane.PaperAssemblyEnv(paper, mask_blocked_moves=True)
    return multicrane.parallel_env(scenario, n_cranes=cranes, auto=auto, **options)


def describe(env) -> str:
    """One line about an environment: scenario, components, cranes, site, step limit."""
    if hasattr(env, "possible_agents"):
        s = env.scenario
        return (
            f"scenario {s.name}: {s.n_components} components, {env.sim.n_cranes} crane(s), "
            f"site {s.size[0]}x{s.size[1]}x{s.size[2]}, step limit {env.step_limit}"
            + (", automatic mode" if env.auto else "")
        )
    return f"paper configuration {env.config}"


def counting(advance):
    """A ``progress`` for ``multicrane.episodes.rollout.evaluate``: passes the seeds through and
    advances a bar (``multicrane.cli.progress``) by one after each episode."""

    def wrap(seeds):
        for seed in seeds:
            yield seed
            advance(1)

    return wrap
