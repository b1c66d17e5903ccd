"""Episode records: a small file from which an episode can be re-simulated exactly.

    from multicrane.replay.record import EpisodeRecord, record_episode, resimulate
    rec = record_episode(env, policy, seed=3, policy_name="prioritized")
    rec.save("episode.json.gz")                 # JSON; gzip when the name ends in .gz
    env, rewards, final = resimulate(EpisodeRecord.load("episode.json.gz"))

A record holds the scenario (name, source and the SHA-256 of its file), the seed, the number
of cranes, the options (``auto``, ``max_steps``), the joint actions (one list per step, in
agent order), the events of each step (type name, crane, component) and the final metrics
(return, steps, success, and the final component states). A task-mode episode
(``decisions="task"``) is recorded by its physical joint actions and events, which replay in
the motion mode, with the paper reward as its return; its task decisions are kept as
``decisions``. The environment draws each step's
crane order from its generator seeded at reset, so the same seed and actions give the same
episode. :func:`resimulate` refuses a record whose scenario file changed
(:class:`ScenarioMismatchError`) and one whose re-simulation differs from what was recorded
(:class:`RecordMismatchError`, naming each field: recorded vs re-simulated); both are
``ValueError`` subclasses. A saved file carries ``checksum``, the SHA-256 of its canonical
content (see ``multicrane.replay.record_file``): a file changed after it was written, or one that
cannot be read (corrupt gzip, bad JSON, truncated), is a :class:`RecordError` naming the file
and the problem. Files written before checksums existed load with a ``RecordWarning``.
An episode with site events (``multicrane.sim.events``) also stores its drawn ``schedule``,
which the re-simulation uses as is (``reset(options={"schedule": ...})``); a record without
one (older files included) re-simulates without events.

This module does not import rerun (see ``multicrane.replay.viewer`` for the 3D viewer).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Protocol

from multicrane.core.schema import Scenario
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.episodes.rollout import run_episode
from multicrane.replay import record_file
from multicrane.scenario.catalog import scenario_names, scenarios_dir
from multicrane.scenario.loader import load_scenario
from multicrane.sim.events import EventSchedule, EventSpec

RECORD_FORMAT = 1

EventRow = tuple[str, int, int]  # (event type name, crane, component or -1)


RecordError = record_file.RecordError
RecordWarning = record_file.RecordWarning


class ScenarioMismatchError(RecordError):
    """The record's scenario file changed since it was recorded (its hash differs)."""


class RecordMismatchError(RecordError):
    """Re-simulating the record did not reproduce the recorded episode."""


class StepListener(Protocol):
    """Something told of an episode's reset and each step as it runs (e.g. the 3D replay
    collector and live viewer of ``multicrane.replay.viewer``)."""

    def on_reset(self, env: MultiCraneEnv) -> None: ...

    def on_step(
        self, env: MultiCraneEnv, actions: list[int], reward: float, events: list[EventRow]
    ) -> None: ...


@dataclass
class EpisodeRecord:
    """One episode: enough to re-simulate it exactly, and what it achieved."""

    scenario: str  # scenario name
    scenario_sha256: str
    scenario_source: str  # the file it was loaded from (a shipped name is tried if missing)
    seed: int
    n_cranes: int
    auto: bool
    max_steps: int
    actions: list[list[int]] = field(default_factory=list)
    events: list[list[EventRow]] = field(default_factory=list)
    metrics: dict[str, Any] = field(default_factory=dict)
    policy: str = ""
    format: int = RECORD_FORMAT
    # Task mode: the task decisions, one list per decision round (``actions`` then hold the
    # physical joint actions, which re-simulate in the motion mode). Absent in motion mode.
    decisions: list[list[int]] = field(default_factory=list)
    # Site events: the drawn schedule (``EventSchedule.to_json``); empty: no events.
    schedule: dict[str, Any] = field(default_factory=dict)

    @property
    def steps(self) -> int:
        return len(self.actions)

    # -- files ---------------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        data = asdict(self)
        data["events"] = [[list(e) for e in step] for step in self.events]
        if not self.decisions:
            del data["decisions"]
        if not self.schedule:
            del data["schedule"]
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "<dict>") -> EpisodeRecord:
        """A record from its dict, every field checked for type (no coercion: 2.7 is not 2)."""
        if not isinstance(data, dict):
            raise RecordError(f"{source}: not an episode record (top level is not an object)")
        fmt = data.get("format")
        if fmt != RECORD_FORMAT or isinstance(fmt, bool):
            raise RecordError(f"{source}: record format {fmt!r} is not {RECORD_FORMAT}")
        f = record_file.Fields(source, data)
        return cls(
            scenario=f.text("scenario"),
            scenario_sha256=f.text("scenario_sha256"),
            scenario_source=f.text("scenario_source", ""),
            seed=f.integer("seed"),
            n_cranes=f.integer("n_cranes", 1),
            auto=f.flag("auto"),
            max_steps=f.integer("max_steps", 1),
            actions=f.actions("actions"),
            events=f.events("events"),
            metrics=f.metrics("metrics"),
            policy=f.text("policy", ""),
            decisions=f.actions("decisions", []),
            schedule=f.table("schedule", {}),
        )

    def save(self, path: str | Path) -> Path:
        """Write JSON with its checksum (gzip-compressed when the name ends in ``.gz``)."""
        return record_file.write(path, self.to_dict())

    @classmethod
    def load(cls, path: str | Path) -> EpisodeRecord:
        """Read a record file, checking its checksum; any problem is one RecordError."""
        return cls.from_dict(record_file.read(path), source=str(path))

    # -- the scenario --------------------------------------------------------------------

    def load_scenario(self, scenario: str | Path | Scenario | None = None) -> Scenario:
        """The record's scenario (or ``scenario`` if given), checked against the stored hash."""
        if scenario is None:
            source = Path(self.scenario_source) if self.scenario_source else None
            if source is not None and source.is_file():
                scenario = source
            elif self.scenario.lower() in scenario_names():
                scenario = self.scenario
            else:
                raise RecordError(
                    f"episode record: scenario {self.scenario!r} not found "
                    f"(file {self.scenario_source!r} missing and not a shipped name)"
                )
        s = load_scenario(scenario)
        if s.sha256 != self.scenario_sha256:
            raise ScenarioMismatchError(
                f"episode record refused: scenario {self.scenario!r} ({s.source}) no longer "
                f"matches the record: recorded hash {self.scenario_sha256}, current file hash "
                f"{s.sha256}; the scenario changed since the episode was recorded"
            )
        return s

    def make_env(self, scenario: str | Path | Scenario | None = None) -> MultiCraneEnv:
        """A fresh environment configured as the recorded one (not yet reset)."""
        return MultiCraneEnv(
            self.load_scenario(scenario),
            n_cranes=self.n_cranes,
            auto=self.auto,
            max_steps=self.max_steps,
            events=EventSpec() if self.schedule else None,
        )

    def event_schedule(self, env: MultiCraneEnv) -> EventSchedule | None:
        """The stored schedule for ``env``'s site (None without events)."""
        if not self.schedule:
            return None
        try:
            return EventSchedule.from_json(self.schedule, env.sim.site)
        except (KeyError, TypeError, ValueError) as exc:
            raise RecordError(f"episode record: bad events schedule: {exc!r}") from None


# ---------------------------------------------------------------------------------------------
# Recording


def _events_of(env: MultiCraneEnv, infos: dict) -> list[EventRow]:
    """The step's events, read from the environment (its infos hold only counts)."""
    return [
        (e.type.name, int(e.crane), int(e.component))
        for crane_events in env.unwrapped.last_events
        for e in crane_events
    ]


def _source_name(s: Scenario) -> str:
    """A shipped scenario is stored by name (portable across installs), else by path."""
    try:
        shipped = Path(s.source).resolve().parent == scenarios_dir().resolve()
    except OSError:
        shipped = False
    return s.name if shipped else str(Path(s.source).resolve())


def final_state(env: MultiCraneEnv) -> dict[str, Any]:
    """The end state that a re-simulation must reproduce: statuses, cells, held, step."""
    sim = env.sim
    return {
        "status": [int(s) for s in sim.state.status],
        "cells": [sorted(sim.site.cell(j) for j in cells) for cells in sim.state.cells],
        "held": [int(h) for h in sim.state.held],
        "step": int(sim.state.step_count),
    }


def record_episode(
    env: MultiCraneEnv,
    policy: Callable[[dict], dict],
    seed: int,
    policy_name: str = "",
    listeners: Sequence[StepListener] = (),
) -> EpisodeRecord:
    """Run one episode of ``env`` with ``policy`` from ``seed`` and record it.

    ``listeners`` see the reset and every step (a 3D replay collector, a live viewer).
    """
    s = env.scenario
    rec = EpisodeRecord(
        scenario=s.name,
        scenario_sha256=s.sha256,
        scenario_source=_source_name(s),
        seed=int(seed),
        n_cranes=env.sim.n_cranes,
        auto=bool(env.auto),
        max_steps=int(env.step_limit),
        policy=policy_name,
    )
    def on_reset(env: MultiCraneEnv) -> None:
        for listener in listeners:
            listener.on_reset(env)

    def on_step(env: MultiCraneEnv, joint: list[int], reward: float, infos: dict) -> None:
        events = _events_of(env, infos)
        rec.actions.append(joint)
        rec.events.append(events)
        for listener in listeners:
            listener.on_step(env, joint, reward, events)

    m = run_episode(env, policy, int(seed), on_reset=on_reset, on_step=on_step)
    mode = env.mode
    if mode.task_level:  # keep the physical steps: they re-simulate in motion mode
        rec.decisions = rec.actions
        rec.actions = [list(joint) for joint in mode.trace]
        rec.events = [
            [(e.type.name, int(e.crane), int(e.component)) for e in step]
            for step in (sorted(s, key=lambda e: e.crane) for s in mode.trace_events)
        ]
        m = dict(m, **{"return": float(sum(mode.trace_rewards))})
    if env.sim.schedule is not None:
        rec.schedule = env.sim.schedule.to_json()
    rec.metrics = {
        "return": m["return"],
        "steps": m["steps"],
        "success": m["success"],
        "final_status": [int(x) for x in env.sim.state.status],
    }
    return rec


# ---------------------------------------------------------------------------------------------
# Re-simulation


def resimulate_steps(
    record: EpisodeRecord,
    scenario: str | Path | Scenario | None = None,
    listeners: Sequence[StepListener] = (),
    check: bool = True,
) -> Iterator[tuple[MultiCraneEnv, int, float, list[EventRow]]]:
    """Re-simulate a record step by step: yields ``(env, step, reward, events)``, first for
    the reset (step 0, reward 0), then after each step. With ``check`` every step's events
    must equal the recorded ones, and after the last step the recorded end metrics (return,
    steps, success, final states) must be reproduced, else :class:`RecordMismatchError`
    naming each field that differs (see :func:`end_differences`)."""
    try:
        env = record.make_env(scenario)
        env.reset(seed=record.seed, options={"schedule": record.event_schedule(env)})
    except RecordError:
        raise
    except ValueError as exc:  # a scenario, crane count or seed that cannot be used
        raise RecordError(f"episode record: cannot set up its environment: {exc}") from None
    agents = env.possible_agents
    if len(agents) != record.n_cranes:
        raise RecordError(f"episode record: {record.n_cranes} cranes, env has {len(agents)}")
    for listener in listeners:
        listener.on_reset(env)
    total = 0.0
    yield env, 0, 0.0, []
    for t, joint in enumerate(record.actions, start=1):
        if not env.agents:
            raise RecordMismatchError(
                f"episode record refused: the re-simulated episode of {record.scenario!r} "
                f"ended after {t - 1} steps but the record has {record.steps}"
            )
        if len(joint) != len(agents):
            raise RecordError(
                f"episode record: step {t} has {len(joint)} actions, not {len(agents)}"
            )
        try:
            _, rewards, _, _, infos = env.step(dict(zip(agents, joint, strict=True)))
        except ValueError as exc:  # an action outside the action space
            raise RecordError(f"episode record: step {t}: {exc}") from None
        r = float(rewards[agents[0]])
        total += r
        events = _events_of(env, infos)
        if check and t <= len(record.events) and events != list(record.events[t - 1]):
            raise RecordMismatchError(
                f"episode record refused: step {t} of {record.scenario!r} re-simulates to "
                f"events {events} but the record has {list(record.events[t - 1])}"
            )
        for listener in listeners:
            listener.on_step(env, joint, r, events)
        if check and t == record.steps:
            _verify_end(record, env, total)
        yield env, t, r, events
    if check and not record.steps:
        _verify_end(record, env, total)


def end_differences(record: EpisodeRecord, env: MultiCraneEnv, total: float) -> list[str]:
    """Each recorded end metric that the re-simulated episode does not reproduce, as
    ``field: recorded X, re-simulated Y`` (empty when all agree)."""
    m = record.metrics
    out = []
    if env.agents:
        out.append(f"end: the record ends after {record.steps} steps, the episode goes on")
    if "return" in m and abs(total - float(m["return"])) > 1e-6 * max(1.0, abs(total)):
        out.append(f"return: recorded {float(m['return']):g}, re-simulated {total:g}")
    steps = int(env.sim.state.step_count)
    if "steps" in m and int(m["steps"]) != steps:
        out.append(f"steps: recorded {m['steps']}, re-simulated {steps}")
    success = bool(env.sim.done)
    if "success" in m and bool(m["success"]) != success:
        out.append(f"success: recorded {m['success']}, re-simulated {success}")
    status = [int(x) for x in env.sim.state.status]
    if "final_status" in m and list(m["final_status"]) != status:
        out.append(f"final_status: recorded {list(m['final_status'])}, re-simulated {status}")
    return out


def _verify_end(record: EpisodeRecord, env: MultiCraneEnv, total: float) -> None:
    problems = end_differences(record, env, total)
    if problems:
        raise RecordMismatchError(
            f"episode record refused: {record.scenario!r} (seed {record.seed}): "
            + "; ".join(problems)
        )


def resimulate(
    record: EpisodeRecord,
    scenario: str | Path | Scenario | None = None,
    listeners: Sequence[StepListener] = (),
) -> tuple[MultiCraneEnv, list[float], dict[str, Any]]:
    """Re-simulate a record exactly: ``(env, per-step rewards, final state)``.

    Raises :class:`ScenarioMismatchError` when the scenario file changed and
    :class:`RecordMismatchError` when the re-simulation does not reproduce the recorded
    events, return, length or final states.
    """
    rewards: list[float] = []
    env = None
    for step_env, t, r, _ in resimulate_steps(record, scenario, listeners):
        env = step_env
        if t:
            rewards.append(r)
    assert env is not None
    return env, rewards, final_state(env)


__all__ = [
    "EpisodeRecord",
    "RecordError",
    "RecordMismatchError",
    "RecordWarning",
    "end_differences",
    "ScenarioMismatchError",
    "StepListener",
    "final_state",
    "record_episode",
    "resimulate_steps",
    "resimulate",
]
