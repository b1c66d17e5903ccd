"""The planner's hint in the set observation (``SetLimits.hint``, ``--planner-hint``): the
``proposed`` column, the network's use of it, and the training run that reads it."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("sb3_contrib")

import torch as th  # noqa: E402
from conftest import cloned_set_run  # noqa: E402

import policies  # noqa: E402
from multicrane.envs.crane_env import MultiCraneEnv  # noqa: E402
from multicrane.sim.simulator import NOBODY  # noqa: E402
from multicrane.training import train  # noqa: E402
from multicrane.training.model_policy import SetModelPolicy, load_run  # noqa: E402
from multicrane.training.set_obs import N_TASK, Padder, SetLimits  # noqa: E402
from multicrane.training.set_training import make_set_model, set_hyperparameters  # noqa: E402
from multicrane.training.set_vec_env import SetVecEnv  # noqa: E402
from policies.task_planners import TaskPrioritized  # noqa: E402

th.set_num_threads(1)


def _env(name="hall-4c", cranes=4):
    return MultiCraneEnv(name, n_cranes=cranes, decisions="task")


def _play(env, policy, seed):
    obs, _ = env.reset(seed=seed)
    while env.agents:
        obs, *_ = env.step(policy(obs))
    return env.mode.trace, env.sim.state.step_count


def test_the_hint_column_marks_the_planners_task_and_nothing_else():
    env = _env()
    plain_limits = SetLimits(29, 4, 300)
    hint_limits = SetLimits(29, 4, 300, hint=True)
    plain, hinted = (
        Padder(env.observation_layout, plain_limits),
        Padder(env.observation_layout, hint_limits, env),
    )
    planner = TaskPrioritized(env)
    obs, _ = env.reset(seed=2)
    marked = 0
    for _ in range(12):
        proposed = hinted.proposals()
        tasks_at, _, (P, width) = hint_limits.slices()["tasks"]
        for k, agent in enumerate(env.possible_agents):
            a = plain.pad(obs[agent]["observation"])
            b = hinted.pad(obs[agent]["observation"], proposed=proposed[k])
            rows = b[tasks_at : tasks_at + P * width].reshape(P, width)
            assert width == N_TASK + 1
            assert np.flatnonzero(rows[:, N_TASK]).tolist() == (
                [proposed[k]] if proposed[k] != NOBODY else []
            )
            plain_rows = a[tasks_at : tasks_at + P * N_TASK].reshape(P, N_TASK)
            assert np.array_equal(rows[:, :N_TASK], plain_rows)
            assert np.array_equal(a[:tasks_at], b[:tasks_at])
            marked += proposed[k] != NOBODY
        joint = planner(obs)
        assert [joint[a] - 1 if joint[a] else NOBODY for a in env.possible_agents] == proposed
        obs, *_ = env.step(joint)
    assert marked >= 4


def test_a_network_that_trusts_the_hint_plays_the_planners_episode():
    """With large hint weights, the untrained network's greedy choice is the planner's."""
    env = _env("hall-4c", 3)
    limits = SetLimits.of(env.observation_layout)
    limits = SetLimits(limits.components, limits.cranes, limits.tasks, hint=True)
    venv = SetVecEnv(lambda i: _env("hall-4c", 3), 1, limits)
    model = make_set_model(venv, 0, set_hyperparameters({"n_steps": 8, "batch_size": 8}), None)
    ex = model.policy.features_extractor
    with th.no_grad():
        ex.hint_gain.fill_(1e3)
        ex.hint_wait.fill_(1e3)
    for seed in (0, 5):
        learned = _play(env, SetModelPolicy(model, env, break_waits=False), seed)
        assert learned == _play(env, TaskPrioritized(env), seed)


def test_imitating_the_planner_with_its_hint_reproduces_it(tmp_path):
    """Two episodes of the prioritized planner and a few epochs: the policy plays the
    planner's episodes on held-out seeds, and the run's saved model keeps the hint."""
    cfg = cloned_set_run("e3s2", 2, planner_hint=True, imitate_epochs=4)
    out = tmp_path / "run"
    train(cfg, out, teacher=policies.factory("prioritized"), log=lambda *a: None)
    model, loaded = load_run(out)
    assert loaded.planner_hint
    env = _env("e3s2", 2)
    policy = SetModelPolicy(model, env)
    assert policy.actor.limits.hint
    for seed in (1000, 1001):
        assert _play(env, policy, seed) == _play(env, TaskPrioritized(env), seed)
