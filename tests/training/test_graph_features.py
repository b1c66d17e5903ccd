"""The support graph's columns in the set observation (``SetLimits.graph``,
``--graph-features``): their values, their place beside the hint, and a run that keeps them;
and the checks both options of the set observation (this and the planner's hint) share."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("sb3_contrib")

import torch as th  # noqa: E402
from conftest import cloned_set_run  # noqa: E402

import policies  # noqa: E402
from multicrane.envs.crane_env import MultiCraneEnv  # noqa: E402
from multicrane.sim.simulator import NOBODY  # noqa: E402
from multicrane.tasks.support_graph import support_chains  # noqa: E402
from multicrane.training import TrainConfig, train  # noqa: E402
from multicrane.training.config import ConfigError  # noqa: E402
from multicrane.training.model_policy import SetModelPolicy, load_run  # noqa: E402
from multicrane.training.set_obs import N_TASK, Padder, SetLimits  # noqa: E402
from multicrane.training.set_training import limits_of  # noqa: E402

th.set_num_threads(1)


def _env(name="hall-4c", cranes=4):
    return MultiCraneEnv(name, n_cranes=cranes, decisions="task")


def _task_rows(vector, limits):
    at, _, (P, width) = limits.slices()["tasks"]
    return vector[at : at + P * width].reshape(P, width)


@pytest.mark.parametrize(("name", "cranes", "hint"), [("hall-4c", 4, False),
                                                      ("frame2-3c", 3, True)])  # fmt: skip
def test_the_graph_columns_show_each_tasks_target_and_leave_the_rest(name, cranes, hint):
    env = _env(name, cranes)
    layout = env.observation_layout
    exact = SetLimits.of(layout)
    limits = SetLimits(exact.components + 2, exact.cranes + 1, exact.tasks + 5, hint=hint,
                       graph=True)  # fmt: skip
    plain = SetLimits(limits.components, limits.cranes, limits.tasks, hint=hint)
    with_graph, without = Padder(layout, limits, env), Padder(layout, plain, env)
    chain, dependents = support_chains(env.sim.site.target_supports)
    assert chain.max() >= 1 and dependents.max() >= 2  # the site has supports to show
    targets = np.array([t for _, t in env.mode.task_book().tasks.pairs])
    want = np.stack([chain[targets] / chain.max(), dependents[targets] / (len(chain) - 1)], 1)
    obs, _ = env.reset(seed=3)
    for _ in range(6):
        proposed = with_graph.proposals()
        for k, agent in enumerate(env.possible_agents):
            a = with_graph.pad(obs[agent]["observation"], proposed=proposed[k])
            b = without.pad(obs[agent]["observation"], proposed=proposed[k])
            rows, plain_rows = _task_rows(a, limits), _task_rows(b, plain)
            first = N_TASK + hint
            assert rows.shape[1] == first + 2
            assert np.allclose(rows[: len(targets), first:], want)
            assert not rows[len(targets) :, first:].any()  # padded tasks show nothing
            assert np.array_equal(rows[:, :first], plain_rows)
            tasks_at = limits.slices()["tasks"][0]
            assert np.array_equal(a[:tasks_at], b[:tasks_at])
            assert a.min() >= 0.0 and a[tasks_at:].max() <= 1.0
        joint = {agent: int(np.flatnonzero(obs[agent]["action_mask"])[-1]) for agent in obs}
        obs, *_ = env.step(joint)
        if not env.agents:
            break


@pytest.mark.parametrize(("flag", "option", "what"), [
    ("hint", "planner_hint", "the planner's hint"),
    ("graph", "graph_features", "the support graph's columns"),
])  # fmt: skip
def test_the_set_options_need_the_environment_and_a_set_policy(flag, option, what):
    """Both options of the set observation: refused without the environment, as non-bools,
    without a set policy; on in the run's limits, its saved dict and the task row's width."""
    env = _env()
    with pytest.raises(ValueError, match=f"{what} need the environment"):
        Padder(env.observation_layout, SetLimits(29, 4, 289, **{flag: True}))
    with pytest.raises(ValueError, match=f"{flag}=1"):
        SetLimits(29, 4, 289, **{flag: 1})
    with pytest.raises(ConfigError, match=f"{option}=True: needs policy='set'"):
        TrainConfig("hall-4c", paper=False, n_cranes=4, **{option: True})
    with pytest.raises(ConfigError, match=f"{option}='yes': must be true or false"):
        TrainConfig("hall-4c", paper=False, n_cranes=4, **{option: "yes"})
    cfg = TrainConfig("hall-4c", paper=False, n_cranes=4, decisions="task",
                      algo="maskable_ppo", policy="set", **{option: True})  # fmt: skip
    assert limits_of(cfg) == SetLimits(29, 4, 289, **{flag: True})
    assert limits_of(cfg).to_dict() == {"components": 29, "cranes": 4, "tasks": 289,
                                        flag: True}  # fmt: skip
    assert limits_of(cfg).task_width == N_TASK + {"hint": 1, "graph": 2}[flag]


def test_a_run_with_the_graph_columns_keeps_them_and_plays_bigger_sites(tmp_path):
    """A short imitation run on e3s2: the saved model reads the columns again when loaded,
    on its own site and, resized, on a bigger one."""
    cfg = cloned_set_run("e3s2", 2, graph_features=True, imitate_epochs=2)
    out = tmp_path / "run"
    train(cfg, out, teacher=policies.factory("prioritized"), log=lambda *a: None)
    model, loaded = load_run(out)
    assert loaded.graph_features
    for name, cranes in (("e3s2", 2), ("hall-4c", 4)):
        env = _env(name, cranes)
        policy = SetModelPolicy(model, env)
        assert policy.actor.limits.graph and not policy.actor.limits.hint
        obs, _ = env.reset(seed=7)
        for _ in range(3):
            joint = policy(obs)
            assert all(obs[a]["action_mask"][joint[a]] for a in obs)
            obs, *_ = env.step(joint)
        assert policy.padder.proposals() == [NOBODY] * cranes
