"""Potential-based shaping of the multi-agent training reward (``multicrane.training.shaping``):
the potential on hand-checked states, the telescoping sum over whole episodes, and that the
environment's own returns are left alone."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import multicrane  # noqa: E402
from multicrane.core.codes import Status  # noqa: E402
from multicrane.episodes.random_actions import random_legal_action
from multicrane.sim.simulator import NOBODY  # noqa: E402
from multicrane.training.shaping import DistancePotential  # noqa: E402
from multicrane.training.vec_env import CraneVecEnv  # noqa: E402
from policies.greedy import GreedyPolicy  # noqa: E402


def _greedy_episode(shaping: float, gamma: float, seed: int = 0, scenario: str = "e2s2"):
    """One greedy episode through a one-copy CraneVecEnv: (learner rewards, info at the end,
    initial potential)."""
    venv = CraneVecEnv(
        lambda: multicrane.parallel_env(scenario, n_cranes=2), 1, shaping=shaping, gamma=gamma
    )
    venv.seed(seed)
    venv.reset()
    env = venv.envs[0]
    phi0 = DistancePotential(env.sim)()
    policy = GreedyPolicy(env, seed=[seed, 1])
    rewards = []
    while True:
        masks = env.action_masks()
        actions = policy({a: {"action_mask": masks[a]} for a in env.possible_agents})
        _, r, dones, infos = venv.step(np.array([actions[a] for a in env.possible_agents]))
        assert r[0] == r[1], "every crane row gets the same team reward"
        rewards.append(float(r[0]))
        if dones[0]:
            return rewards, infos[0], phi0


def test_potential_is_minus_the_distance_to_the_nearest_free_target():
    env = multicrane.parallel_env("e2s2", n_cranes=1)
    env.reset(seed=0)
    sim = env.sim
    phi = DistancePotential(sim)
    start = phi()
    assert start < 0, "components start away from their targets"
    # Claim the first claimable component and move it one cell along the potential's
    # gradient: the potential changes by exactly one cell.
    comp = sim.claimable_components()[0]
    env.step({"crane_0": 8 + comp})
    assert sim.state.held[0] == comp
    assert phi() == start, "claiming puts the component at its pick-up pose: no change"
    changes = set()
    for move in range(6):
        if not env.action_masks()["crane_0"][move]:
            continue
        snap = sim.snapshot()
        before = phi()
        sim.step([move])
        changes.add(phi() - before)
        sim.restore(snap)
    assert changes <= {-1.0, 1.0}, changes
    assert 1.0 in changes, "some legal move brings the component closer"


def test_potential_is_zero_when_everything_is_assembled():
    env = multicrane.parallel_env("e2s2", n_cranes=2)
    env.reset(seed=0)
    policy = GreedyPolicy(env, seed=0)
    obs = env.reset(seed=0)[0]
    while env.agents:
        obs, *_ = env.step(policy(obs))
    assert env.sim.done
    assert all(int(s) == int(Status.ASSEMBLED) for s in env.sim.state.status)
    assert DistancePotential(env.sim)() == 0.0
    assert all(c == NOBODY for c in env.sim.state.held)


@pytest.mark.parametrize("seed", [0, 1])
def test_shaping_telescopes_over_an_episode(seed):
    plain, info, _ = _greedy_episode(0.0, 0.99, seed)
    assert info["is_success"], "greedy finishes e2s2 with 2 cranes"
    assert sum(plain) == pytest.approx(info["episode"]["r"])
    # gamma = 1: the shaping terms add up to w * (phi(end) - phi(start)) = -w * phi(start).
    for w in (0.5, 2.0):
        shaped, info_w, phi0 = _greedy_episode(w, 1.0, seed)
        assert info_w["episode"]["r"] == pytest.approx(info["episode"]["r"]), (
            "the reported return is the environment's, not the shaped one"
        )
        assert len(shaped) == len(plain)
        assert sum(shaped) == pytest.approx(sum(plain) - w * phi0)
        assert shaped != pytest.approx(plain)


def test_shaping_is_off_by_default_in_paper_mode_and_must_be_non_negative():
    from multicrane.training import ConfigError, TrainConfig

    with pytest.raises(ConfigError, match="shaping"):
        TrainConfig("E1S1", paper=True, shaping=-1.0)
    assert TrainConfig("E1S1", paper=True, shaping=0.5).shaping_weight == 0.5
    with pytest.raises(ConfigError, match="shaping"):
        TrainConfig("e1s1", paper=False, shaping=-1.0)
    with pytest.raises(ValueError, match="shaping"):
        CraneVecEnv(lambda: multicrane.parallel_env("e1s1", n_cranes=2), 1, shaping=-0.5)
    assert TrainConfig("e1s1", paper=False).shaping_weight > 0
    assert TrainConfig("e1s1", paper=False, shaping=0).shaping_weight == 0
    assert TrainConfig("E1S1", paper=True).shaping_weight == 0


@pytest.mark.parametrize(("scenario", "cranes"), [("e3s2", 2), ("hall-4c", 4)])
def test_incremental_potential_equals_the_formula_at_every_step(scenario, cranes):
    """The cached potential equals ``potential_from_scratch`` along planner and random
    steps, after snapshot/restore (the state jumps back) and across resets."""
    from multicrane.training.shaping import potential_from_scratch
    from policies.prioritized import PrioritizedPlanner

    env = multicrane.parallel_env(scenario, n_cranes=cranes)
    obs, _ = env.reset(seed=4)
    phi = DistancePotential(env.sim)
    rng = np.random.default_rng(4)
    plan = PrioritizedPlanner(env, seed=4)
    snap = env.sim.snapshot()
    values = set()
    for step in range(200):
        value = phi()
        assert value == potential_from_scratch(env.sim), step
        values.add(value)
        if step == 100:  # jump back in time: every cache must notice
            env.sim.restore(snap)
            assert phi() == potential_from_scratch(env.sim)
            obs, _ = env.reset(seed=5)
            plan = PrioritizedPlanner(env, seed=5)
            continue
        if not env.agents:
            obs, _ = env.reset()
            plan = PrioritizedPlanner(env, seed=4)
            continue
        if rng.random() < 0.7:
            actions = plan(obs)
        else:
            actions = {
                a: random_legal_action(obs[a]["action_mask"], rng) for a in env.agents
            }
        obs, *_ = env.step(actions)
    assert len(values) > 10
