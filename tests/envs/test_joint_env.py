"""``multicrane/Joint-v0`` (``multicrane.envs.joint_env``): every crane as one Gymnasium agent."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import multicrane
from multicrane.envs.joint_env import JOINT_ENV_ID, JointCraneEnv


@pytest.mark.parametrize(
    ("scenario", "options"),
    [("e2s2", {}), ("hall-4c", {"render_mode": "rgb_array"}), ("frame2-3c", {"decisions": "task"})],
)
def test_gymnasium_check_env_passes(scenario, options, monkeypatch):
    # Through gymnasium.make, so that check_env also renders in every other mode ("human"
    # into an in-memory rerun stream: no viewer window during the tests).
    pytest.importorskip("rerun")
    monkeypatch.setenv("MULTICRANE_RERUN_SINK", "memory")
    check_env(gym.make(JOINT_ENV_ID, scenario=scenario, **options).unwrapped)


def test_spaces_and_masks_are_the_cranes_stacked():
    env = gym.make(JOINT_ENV_ID, scenario="hall-4c")
    multi = multicrane.parallel_env("hall-4c", obs_format="flat")
    n, a = multi.sim.n_cranes, multi.n_actions
    size = multi.observation_space("crane_0").shape[0]
    assert env.action_space == gym.spaces.MultiDiscrete([a] * n)
    assert env.observation_space.shape == (n, size)
    obs, _ = env.reset(seed=3)
    multi_obs, _ = multi.reset(seed=3)
    assert np.array_equal(obs, np.stack([multi_obs[f"crane_{i}"] for i in range(n)]))
    masks = env.unwrapped.action_masks()
    assert masks.shape == (n, a) and masks.dtype == bool
    expected = np.stack([m for m in multi.action_masks().values()]).astype(bool)
    assert np.array_equal(masks, expected)


def test_an_episode_matches_the_multi_agent_env():
    joint = JointCraneEnv("frame2-3c", max_steps=40)
    multi = multicrane.parallel_env("frame2-3c", max_steps=40, obs_format="flat")
    joint.reset(seed=1)
    multi.reset(seed=1)
    rng = np.random.default_rng(1)
    while True:
        action = [int(rng.choice(np.flatnonzero(m))) for m in joint.action_masks()]
        obs, reward, terminated, truncated, info = joint.step(action)
        out = multi.step({f"crane_{i}": a for i, a in enumerate(action)})
        assert np.array_equal(obs, np.stack(list(out[0].values())))
        assert reward == out[1]["crane_0"] and set(info) == set(out[4])
        assert terminated == out[2]["crane_0"] and truncated == out[3]["crane_0"]
        if terminated or truncated:
            break
    assert truncated or terminated


def test_split_rewards_add_up_to_the_joint_reward():
    joint = JointCraneEnv("frame2-3c", reward_mode="split")
    multi = multicrane.parallel_env("frame2-3c", reward_mode="split", obs_format="flat")
    joint.reset(seed=0)
    multi.reset(seed=0)
    action = [int(np.flatnonzero(m)[-1]) for m in joint.action_masks()]
    reward = joint.step(action)[1]
    rewards = multi.step({f"crane_{i}": a for i, a in enumerate(action)})[1]
    assert reward == pytest.approx(sum(rewards.values()))


@pytest.mark.parametrize("mode", ["ansi", "rgb_array"])
def test_render_is_the_multi_agent_envs(mode):
    joint = gym.make(JOINT_ENV_ID, scenario="e3s2", render_mode=mode)
    multi = multicrane.parallel_env("e3s2", render_mode=mode)
    joint.reset(seed=0)
    multi.reset(seed=0)
    if mode == "ansi":
        assert joint.render() == multi.render()
    else:
        assert np.array_equal(joint.render(), multi.render())
