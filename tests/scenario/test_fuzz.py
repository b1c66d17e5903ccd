"""Property-based fuzzing (issue 20) of the scenario loader and the episode record reader.

Scenario files: each case is a shipped scenario with 1-4 mutations (a value replaced by one of
another type or range, a key deleted, an unknown key added, a list element duplicated or
dropped, a coordinate or size nudged), written back as TOML, plus raw byte damage. It must
either raise ``ScenarioError`` or load, and then run 100 random legal joint steps with every
invariant of ``tests/sim/test_invariants.py`` holding. Record files: a saved record with JSON-level
mutations (checksum recomputed or not) or byte damage must load or raise ``RecordError``; a
loaded one must re-simulate or raise ``RecordError``. Nothing else is acceptable.

The default sizes fit the suite; ``-m fuzz`` runs the large sizes (see docs/reliability.md):

    MULTICRANE_FUZZ_EXAMPLES=2000 python -m pytest -m fuzz tests/scenario/test_fuzz.py

and ``python tests/scenario/test_fuzz.py N`` runs N random cases of each kind and prints the outcome
counts and times (the figures of docs/reliability.md).
"""

from __future__ import annotations

import copy
import gzip
import json
import math
import os
import tomllib
import warnings
from typing import Any

import numpy as np
import pytest
from conftest import SCENARIOS, random_masked_actions
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_invariants import Checker

import multicrane
from multicrane.core.schema import ScenarioError
from multicrane.replay import record_file
from multicrane.replay.record import EpisodeRecord, RecordError, record_episode, resimulate
from multicrane.scenario.catalog import resolve
from multicrane.scenario.loader import parse_scenario
from policies.random_policy import RandomPolicy

SOURCES = {name: resolve(name).read_bytes() for name in SCENARIOS}
PARSED = {name: tomllib.loads(raw.decode()) for name, raw in SOURCES.items()}
STEPS = 100
LARGE = int(os.environ.get("MULTICRANE_FUZZ_EXAMPLES", "2000"))


# -- TOML out ------------------------------------------------------------------------------


def toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return (
            "{" + ", ".join(f"{json.dumps(str(k))} = {toml_value(x)}" for k, x in v.items()) + "}"
        )
    raise TypeError(v)


def to_toml(data: dict) -> str:
    return "".join(f"{json.dumps(str(k))} = {toml_value(v)}\n" for k, v in data.items())


# -- mutations -----------------------------------------------------------------------------


def slots(data: Any, out: list) -> list:
    """Every (container, key) pair inside ``data``: dict keys and list indices."""
    if isinstance(data, dict):
        for k, v in data.items():
            out.append((data, k))
            slots(v, out)
    elif isinstance(data, list):
        for i, v in enumerate(data):
            out.append((data, i))
            slots(v, out)
    return out


VALUES = st.one_of(
    st.integers(-3, 40),
    st.sampled_from([0, -1, 2**31, 2**63 - 1, 10**7, 40_000, 257, 65]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(["", "x", "beam", "column", "+x", "-z", "1", "2"]),
    st.booleans(),
    st.lists(st.integers(-2, 30), max_size=4),
    st.just([]),
    st.just({}),
    st.just([[0, 0, 1], [0, 0, 1]]),
)


@st.composite
def mutated_scenario(draw) -> tuple[str, bytes]:
    name = draw(st.sampled_from(SCENARIOS))
    data = copy.deepcopy(PARSED[name])
    for _ in range(draw(st.integers(1, 4))):
        places = slots(data, [])
        if not places:
            break
        box, key = draw(st.sampled_from(places))
        op = draw(st.sampled_from(["replace", "delete", "add", "nudge", "nudge", "copy"]))
        value = box[key]
        if op == "replace":
            box[key] = copy.deepcopy(draw(VALUES))
        elif op == "delete":
            del box[key]
        elif op == "add" and isinstance(value, dict):
            value[draw(st.sampled_from(["extra", "kind", "id", "supports", "min"]))] = (
                copy.deepcopy(draw(VALUES))
            )
        elif op == "copy" and isinstance(box, list):
            box.append(copy.deepcopy(value))  # e.g. a duplicated component or obstacle
        elif isinstance(value, int) and not isinstance(value, bool):
            box[key] = value + draw(st.sampled_from([-2, -1, 1, 2, 5]))
        elif isinstance(value, list) and value and all(type(v) is int for v in value):
            i = draw(st.integers(0, len(value) - 1))
            value[i] += draw(st.sampled_from([-2, -1, 1, 2, 5]))
    raw = to_toml(data).encode()
    if draw(st.integers(0, 9)) == 0:  # byte damage
        i = draw(st.integers(0, len(raw) - 1))
        raw = raw[:i] + draw(st.binary(max_size=3)) + raw[i + draw(st.integers(0, 3)) :]
    return name, raw


def run_scenario_case(name: str, raw: bytes) -> str:
    """``"refused"`` or ``"played"``; any other outcome fails the test."""
    try:
        scenario = parse_scenario(raw, source=f"mutated-{name}.toml")
    except ScenarioError:
        return "refused"
    env = multicrane.parallel_env(scenario, info_events=True, info_mask=True)  # Checker reads them
    rng = np.random.default_rng(0)
    try:
        obs, infos = env.reset(seed=0)
    except ScenarioError as exc:
        # A random start rule whose yard cannot hold every component at once is found by
        # the draw at reset (it gives up after 1000 attempts), not at load.
        assert "random_start found no start" in str(exc), exc
        return "refused"
    checker = Checker(env)
    checker.reset(obs, infos)
    for _ in range(STEPS):
        actions = random_masked_actions(obs, rng)
        obs, rewards, terms, truncs, infos = env.step(actions)
        checker.step(actions, obs, rewards, terms, truncs, infos)
        if not env.agents:
            try:
                obs, infos = env.reset()
            except ScenarioError as exc:
                assert "random_start found no start" in str(exc), exc
                return "refused"
            checker.reset(obs, infos)
    checker.check_fresh_observations(obs)
    return "played"


def test_unmutated_scenarios_play():
    for name in SCENARIOS:
        assert run_scenario_case(name, to_toml(PARSED[name]).encode()) == "played", name


COMMON = dict(
    deadline=None, derandomize=True, database=None, suppress_health_check=list(HealthCheck)
)


@settings(max_examples=400, **COMMON)
@given(mutated_scenario())
def test_fuzz_scenarios(case):
    run_scenario_case(*case)


@pytest.mark.fuzz
@settings(max_examples=LARGE, **{**COMMON, "derandomize": False})
@given(mutated_scenario())
def test_fuzz_scenarios_large(case):
    run_scenario_case(*case)


# -- records ---------------------------------------------------------------------------------


def _record() -> EpisodeRecord:
    env = multicrane.parallel_env("e2s2", n_cranes=2, max_steps=30)
    return record_episode(env, RandomPolicy(1), seed=1, policy_name="random")


RECORD = _record()
RECORD_DICT = RECORD.to_dict()
JSON_VALUES = st.one_of(
    st.integers(-5, 50),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=5),
    st.booleans(),
    st.none(),
    st.lists(st.integers(-2, 20), max_size=3),
    st.just({}),
    st.just([[6, 6]]),
)


@st.composite
def mutated_record(draw) -> tuple[str, bytes]:
    data = copy.deepcopy(RECORD_DICT)
    for _ in range(draw(st.integers(1, 3))):
        places = slots(data, [])
        box, key = draw(st.sampled_from(places))
        op = draw(st.sampled_from(["replace", "delete", "nudge"]))
        if op == "replace":
            box[key] = copy.deepcopy(draw(JSON_VALUES))
        elif op == "delete":
            del box[key]
        elif type(box[key]) is int:
            box[key] += draw(st.sampled_from([-1, 1, 7]))
    how = draw(st.sampled_from(["checksum", "no-checksum", "stale-checksum"]))
    if how == "checksum":
        data[record_file.CHECKSUM] = record_file.checksum(data)
    elif how == "stale-checksum":
        data[record_file.CHECKSUM] = record_file.checksum(RECORD_DICT)
    raw = json.dumps(data).encode()
    suffix = draw(st.sampled_from([".json", ".json.gz"]))
    if suffix == ".json.gz":
        raw = gzip.compress(raw, mtime=0)
    if draw(st.integers(0, 3)) == 0:  # byte damage
        i = draw(st.integers(0, len(raw) - 1))
        raw = raw[:i] + draw(st.binary(max_size=4)) + raw[i + draw(st.integers(0, 4)) :]
    return suffix, raw


def run_record_case(tmp_path, suffix: str, raw: bytes) -> str:
    path = tmp_path / f"case{suffix}"
    path.write_bytes(raw)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", record_file.RecordWarning)
        try:
            rec = EpisodeRecord.load(path)
        except RecordError:
            return "refused"
    try:
        resimulate(rec)
    except RecordError:
        return "mismatch"
    return "replayed"


def test_unmutated_record_replays(tmp_path):
    path = RECORD.save(tmp_path / "r.json.gz")
    assert run_record_case(tmp_path, ".json.gz", path.read_bytes()) == "replayed"


@settings(max_examples=400, **COMMON)
@given(mutated_record())
def test_fuzz_records(tmp_path_factory, case):
    run_record_case(tmp_path_factory.mktemp("rec"), *case)


@pytest.mark.fuzz
@settings(max_examples=LARGE, **{**COMMON, "derandomize": False})
@given(mutated_record())
def test_fuzz_records_large(tmp_path_factory, case):
    run_record_case(tmp_path_factory.mktemp("rec"), *case)


def _figures(n: int) -> None:
    """Outcome counts and times of ``n`` random cases of each kind."""
    import collections
    import tempfile
    import time
    from pathlib import Path

    counts: collections.Counter = collections.Counter()
    quick = settings(max_examples=n, **{**COMMON, "derandomize": False})

    @quick
    @given(mutated_scenario())
    def scenarios(case):
        counts["scenario " + run_scenario_case(*case)] += 1

    tmp = Path(tempfile.mkdtemp())

    @quick
    @given(mutated_record())
    def records(case):
        counts["record " + run_record_case(tmp, *case)] += 1

    t0 = time.perf_counter()
    scenarios()
    t1 = time.perf_counter()
    records()
    t2 = time.perf_counter()
    print(dict(sorted(counts.items())), f"scenarios {t1 - t0:.1f} s, records {t2 - t1:.1f} s")


if __name__ == "__main__":
    import sys

    _figures(int(sys.argv[1]) if len(sys.argv) > 1 else 2000)
