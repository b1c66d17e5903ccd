"""Shared helpers for the environment tests.

``SCENARIOS`` (every shipped scenario, read once at import so that test modules can build their
parametrization from it), ``reach_skip`` (why a scenario cannot run with a crane count under
crane reach), ``random_masked_actions`` (a uniformly random legal action per agent) and
``sizes`` (a run's default-suite size and its full size behind the ``long`` marker),
``play_legal`` (play a policy and check every action against its mask) and
``one_torch_thread`` (a fixture for the training tests) are imported by the test modules
with ``from conftest import ...``; the fixtures below hand the same objects to tests that
prefer fixtures.

Tests marked ``long`` (end-to-end runs: training, Ray clusters, sweeps) are skipped unless
selected with ``-m long``; CI runs them as their own step (``.ci/run``, docs/reliability.md).
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

# Keep numerical libraries to one thread: the suite steps many small environments.
os.environ.setdefault("OMP_NUM_THREADS", "1")

# The tests mirror the library's rooms (tests/sim, tests/envs, ...); a test module may share a
# helper of another room's module by its name (``from test_rules import micro_site``).
for _room in sorted(p for p in Path(__file__).parent.iterdir() if p.is_dir()):
    if not _room.name.startswith((".", "_")) and str(_room) not in sys.path:
        sys.path.append(str(_room))

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from hypothesis import Phase, settings  # noqa: E402

# CI (.ci/run sets MULTICRANE_NO_SHRINK=1) reports a failing example as drawn, with the blob
# that replays it: shrinking an example whose every run plays whole episodes can take longer
# than CI's time limit. Locally hypothesis shrinks as usual.
settings.register_profile(
    "no-shrink", phases=[p for p in Phase if p is not Phase.shrink], print_blob=True
)
if os.environ.get("MULTICRANE_NO_SHRINK") == "1":
    settings.load_profile("no-shrink")

import multicrane  # noqa: E402
from multicrane.episodes.random_actions import random_legal_actions  # noqa: E402

SCENARIOS: list[str] = multicrane.scenario_names()


def pytest_collection_modifyitems(config, items):
    """Skip the ``long`` and ``fuzz`` tests unless the run selects them (``-m long``,
    ``-m fuzz``)."""
    selected = config.getoption("-m") or ""
    for marker, command in (("long", "bash tools/test.sh -m long"),
                            ("fuzz", "bash tools/test.sh -m fuzz")):  # fmt: skip
        if marker in selected:
            continue
        skip = pytest.mark.skip(reason=f"a {marker} run: {command} (CI runs it)")
        for item in items:
            if item.get_closest_marker(marker) is not None:
                item.add_marker(skip)


def sizes(default: int, full: int) -> list:
    """Parameters for one run in two sizes: ``default`` in the default suite, ``full`` behind
    the ``long`` marker (CI runs both), so the default stays fast and nothing is lost."""
    return [default, pytest.param(full, marks=pytest.mark.long)]


def reach_skip(name: str, n_cranes: int | None) -> str | None:
    """Why a shipped scenario cannot run with ``n_cranes`` cranes (a tower-crane scenario
    with crane reach needs enough of its own cranes), or None when it can."""
    from multicrane.scenario.loader import load_scenario
    from multicrane.sim.reach import crane_count_problem

    scenario = load_scenario(name)
    return crane_count_problem(scenario, scenario.cranes if n_cranes is None else n_cranes)


def random_masked_actions(obs: dict, rng: np.random.Generator) -> dict[str, int]:
    """One uniformly random legal action per agent, from ``obs[agent]["action_mask"]``
    (``multicrane.episodes.random_actions``: it refuses a mask that allows nothing)."""
    return random_legal_actions({agent: o["action_mask"] for agent, o in obs.items()}, rng)


@pytest.fixture(scope="session")
def scenarios() -> list[str]:
    """The shipped scenario names."""
    return list(SCENARIOS)


@pytest.fixture
def masked_actions():
    """The ``random_masked_actions`` helper."""
    return random_masked_actions


# The readable infos (events and masks) that these tests assert on; libraries get numbers only
# by default (multicrane.envs.infos).
READABLE = {"info_events": True, "info_mask": True}


def readable_env(*args, **options):
    """``multicrane.parallel_env`` with the readable ``events`` and ``action_mask`` in infos."""
    return multicrane.parallel_env(*args, **READABLE, **options)


def readable_paper_env(*args, **options):
    """``PaperAssemblyEnv`` with the readable ``events``, ``component`` and ``action_mask``."""
    return multicrane.PaperAssemblyEnv(*args, **READABLE, **options)


def play_legal(env, policy, seed: int, steps: int, label: str) -> None:
    """Play ``policy`` on the parallel ``env`` from ``reset(seed)`` for up to ``steps`` steps,
    asserting that every action it sends is allowed by that agent's mask."""
    obs, _ = env.reset(seed=seed)
    for _ in range(steps):
        if not env.agents:
            break
        acts = policy(obs)
        for agent, action in acts.items():
            assert obs[agent]["action_mask"][action], f"{label}: illegal action {action}"
        obs, *_ = env.step(acts)


def cloned_set_run(scenario: str, n_cranes: int, **options):
    """A ``TrainConfig`` of a set policy cloned from two prioritized episodes on a site, with
    no PPO (learning rate 0): the short run the set observation's option tests train."""
    from multicrane.training import TrainConfig

    return TrainConfig(scenario, paper=False, n_cranes=n_cranes, decisions="task",
                       algo="maskable_ppo", policy="set", imitate="prioritized",
                       imitate_episodes=2, reward="makespan", shaping=0.0, total_steps=64,
                       n_envs=2, eval_every=0, eval_episodes=1, checkpoint_every=0,
                       hyperparams={"n_steps": 32, "batch_size": 32, "learning_rate": 0.0},
                       **options)  # fmt: skip


def same(a, b) -> bool:
    """Equal, deeply: arrays by value, lists, tuples and dicts element by element."""
    if isinstance(a, np.ndarray):
        return np.array_equal(a, b)
    if isinstance(a, (list, tuple)):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    return a == b


def load_tool(name: str):
    """The module of ``tools/NAME.py`` (developer programs are scripts, not a package)."""
    import importlib.util

    path = Path(__file__).parents[1] / "tools" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def one_torch_thread():
    """One torch thread: on a shared 2-core machine two threads make SB3 many times slower."""
    import torch

    previous = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(previous)
