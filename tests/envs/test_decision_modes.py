"""Decision modes as one interface (``multicrane.envs.decision_modes``): the table by name and
its error, a new mode added as one class and one table row, and what a planner may ask."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test

import multicrane
import policies
from multicrane.core.codes import WAIT
from multicrane.envs.decision_modes import (
    DECISION_MODES,
    MotionMode,
    TaskMode,
    decision_mode,
    task_level,
)
from multicrane.episodes.rollout import run_episode
from policies.task_planners import TaskGreedy


class WaitOnlyMode(MotionMode):
    """A new decision mode in one class: one action, and every crane waits."""

    wait_action = 0

    def __init__(self, sim, settings):
        super().__init__(sim, settings)
        self.n_actions = 1

    def step(self, joint):
        return super().step([WAIT] * len(joint))

    def observe(self):
        rows, _ = super().observe()
        return rows, [np.ones(1, dtype=np.int8) for _ in rows]

    def describe(self, action):
        return "wait"


@pytest.fixture
def wait_only(monkeypatch):
    """``"wait-only"`` in the table for one test (the row is gone after it)."""
    monkeypatch.setitem(DECISION_MODES, "wait-only", WaitOnlyMode)
    return "wait-only"


# -- the table -----------------------------------------------------------------------------------


@pytest.mark.parametrize(("name", "cls"), [("motion", MotionMode), ("task", TaskMode)])
def test_the_table_gives_each_shipped_mode_by_name(name, cls):
    assert decision_mode(name) is cls
    env = multicrane.parallel_env("e3s2", n_cranes=2, decisions=name)
    assert type(env.mode) is cls and env.decisions == name
    assert env.observer is env.mode.observer
    assert env.n_actions == env.mode.n_actions == env.action_space("crane_0").n
    assert env.wait_action == env.mode.wait_action
    assert task_level(env) == (name == "task")


@pytest.mark.parametrize("bad", ["moves", "Task", "", None, 3, ["task"]])
def test_an_unknown_mode_is_refused_with_the_valid_names(bad):
    for make in (decision_mode, lambda name: multicrane.parallel_env("e2s2", decisions=name)):
        with pytest.raises(ValueError, match="decisions must be one of") as info:
            make(bad)
        message = str(info.value)
        assert repr(bad) in message
        assert "'motion'" in message and "'task'" in message


def test_the_error_names_a_registered_mode(wait_only):
    with pytest.raises(ValueError, match="'wait-only'"):
        decision_mode("waits")


def test_the_registered_mode_is_gone_after_its_test():
    assert set(DECISION_MODES) == {"motion", "task"}


def test_task_level_of_environments_without_a_mode():
    assert not task_level(SimpleNamespace(sim=None, decisions="task"))  # a planner's stand-in
    assert not task_level(multicrane.PaperAssemblyEnv("E1S1"))
    assert task_level(multicrane.env("e2s2", decisions="task"))  # through the AEC wrapper


# -- a new mode: one class and one table row -----------------------------------------------------


def test_a_new_mode_plays_through_the_public_constructor(wait_only):
    env = multicrane.parallel_env("e2s2", n_cranes=2, decisions=wait_only, max_steps=5)
    assert env.decisions == "wait-only" and type(env.mode) is WaitOnlyMode
    assert env.action_space("crane_0").n == 1 and env.wait_action == 0
    obs, infos = env.reset(seed=0)
    start = env.sim.state.status.copy()
    assert set(infos["crane_0"]) == {"event_counts", "reward_term"}  # no task facts
    steps = 0
    while env.agents:
        for a in env.possible_agents:
            assert env.observation_space(a).contains(obs[a])
            assert obs[a]["action_mask"].tolist() == [1]
        assert {a: m.tolist() for a, m in env.action_masks().items()} == {
            "crane_0": [1], "crane_1": [1]
        }
        obs, _, terminations, truncations, _ = env.step(dict.fromkeys(env.possible_agents, 0))
        steps += 1
    assert steps == 5 == env.sim.state.step_count
    assert truncations["crane_0"] and not terminations["crane_0"]
    assert np.array_equal(env.sim.state.status, start)  # nobody moved


@pytest.mark.filterwarnings("ignore:Observation is not a NumPy array")
def test_a_new_mode_passes_the_pettingzoo_api_test(wait_only):
    parallel_api_test(multicrane.parallel_env("e2s2", n_cranes=2, decisions=wait_only),
                      num_cycles=10)  # fmt: skip


# -- what a planner may ask ----------------------------------------------------------------------


def test_the_task_book_and_the_carrier_stats_come_from_the_mode():
    env = multicrane.parallel_env("e3s2", n_cranes=2, decisions="task")
    planner = policies.make("prioritized", env, seed=0)
    assert run_episode(env, planner, seed=0)["success"]
    book = env.mode.task_book()
    assert env.action_space("crane_0").n == 1 + len(book.tasks)
    assert planner.stats is env.mode.carrier_stats() and planner.stats["searches"] > 0
    assert not any(value is env for value in vars(env.mode).values())  # no way back up


def test_the_motion_mode_refuses_the_task_questions():
    env = multicrane.parallel_env("e3s2", n_cranes=2)
    env.reset(seed=0)
    with pytest.raises(RuntimeError, match="needs decisions='task'"):
        env.task_feasible(0, 0)
    for ask in (env.mode.task_book, env.mode.carrier_stats):
        with pytest.raises(ValueError, match="decisions='task'"):
            ask()
    with pytest.raises(ValueError, match="task-level planners"):
        TaskGreedy(env)


@pytest.mark.parametrize("n", [2, 3, 4, 7])
def test_the_crane_order_is_the_generators_permutation(n):
    """``physical_step`` draws each step's crane order as ``rng.permutation(n)`` does (the vector
    env replays those draws, ``multicrane.vector.pcg64``): the same orders, and the generator
    left in the same state."""
    from multicrane.envs import motion_mode

    orders = []

    class Recorder:
        n_cranes = n

        def step(self, joint, order):
            orders.append(order)
            raise StopIteration  # the order is all this test looks at

    for seed in range(50):
        rng, twin = np.random.default_rng(seed), np.random.default_rng(seed)
        for _ in range(3):
            with pytest.raises(StopIteration):
                motion_mode.physical_step(Recorder(), rng, "paper", [WAIT] * n)
            assert orders[-1] == twin.permutation(n).tolist()
        assert rng.bit_generator.state == twin.bit_generator.state
