"""``PaperVectorEnv`` as a Gymnasium vector env: registration, spaces, seeds, buffers, errors.

The numbers themselves are compared with the one-site env in test_paper_differential.py;
here: ``gymnasium.make_vec`` returns it for every paper id, the spaces and the autoreset mode
are declared, seeding is reproducible, the uint8 option and ``copy`` behave, infos carry
their masks, and bad input gets the one-site env's errors, naming the copy.
"""

from __future__ import annotations

import re

import gymnasium
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import multicrane
from multicrane.core.schema import ScenarioError
from multicrane.envs.boundary import ActionTypeError
from multicrane.envs.infos import N_EVENT_TYPES
from multicrane.envs.paper_env import PAPER_CONFIGS, PaperAssemblyEnv, paper_env_id
from multicrane.vector.paper_site import compile_site
from multicrane.vector.paper_vector_env import PaperVectorEnv


@pytest.mark.parametrize("config", PAPER_CONFIGS)
def test_make_vec_returns_the_vector_env(config):
    env = gymnasium.make_vec(paper_env_id(config), num_envs=4,
                             vectorization_mode="vector_entry_point")  # fmt: skip
    assert isinstance(env, PaperVectorEnv) and env.config == config
    assert env.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    obs, infos = env.reset(seed=0)
    assert obs.shape == (4, 1350) and env.observation_space.contains(obs)
    assert env.single_observation_space == PaperAssemblyEnv(config).observation_space
    assert env.action_space == gymnasium.spaces.MultiDiscrete([6] * 4)
    assert env.action_masks().shape == (4, 6)


def test_seeding_is_reproducible_and_reset_goes_on():
    env = PaperVectorEnv(8, config="E3S1")
    first = env.reset(seed=5)[0].copy()
    assert not all(np.array_equal(first[0], row) for row in first[1:])  # copies differ
    second = env.reset()[0].copy()  # each copy's generator goes on: new starts
    assert not np.array_equal(first, second)
    assert np.array_equal(env.reset(seed=5)[0], first)
    assert np.array_equal(env.reset(seed=list(range(8)))[0][3], PaperAssemblyEnv("E3S1").reset(
        seed=3)[0])  # fmt: skip
    with pytest.raises(ValueError, match="one seed per copy"):
        env.reset(seed=[1, 2])


def test_uint8_observations_hold_the_same_values():
    floats = PaperVectorEnv(5, config="E4S3")
    small = PaperVectorEnv(5, config="E4S3", obs_dtype=np.uint8)
    a, _ = floats.reset(seed=2)
    b, _ = small.reset(seed=2)
    assert b.dtype == np.uint8 and small.observation_space.dtype == np.uint8
    actions = np.random.default_rng(0).integers(6, size=(300, 5))
    for row in actions:
        assert np.array_equal(a, b)
        a = floats.step(row)[0]
        b = small.step(row)[0]
    with pytest.raises(ValueError, match="obs_dtype"):
        PaperVectorEnv(2, obs_dtype=np.float64)


def test_buffers_are_reused_unless_copy_is_asked():
    env = PaperVectorEnv(3)
    obs, _ = env.reset(seed=0)
    assert env.step([0, 1, 2])[0] is obs
    fresh = PaperVectorEnv(3, copy=True)
    obs, _ = fresh.reset(seed=0)
    assert fresh.step([0, 1, 2])[0] is not obs


def test_infos_carry_their_masks_and_the_final_observation():
    env = PaperVectorEnv(2, config="E1S2")
    env.reset(seed=0)
    for _ in range(99):
        *_, infos = env.step([0, 0])
        assert not infos["_is_success"].any() and not infos["_final_obs"].any()
    obs, rewards, terminated, truncated, infos = env.step([0, 0])
    assert truncated.all() and not terminated.any()  # the step limit, 100
    assert infos["_final_obs"].all() and infos["_is_success"].all()
    assert not infos["is_success"].any()
    assert infos["event_counts"].shape == (2, N_EVENT_TYPES) and infos["_event_counts"].all()
    assert not np.array_equal(infos["final_obs"], obs)  # obs is the new episode's first


def _bad_inputs():
    moves = "action must be 0..5 (x-1, y-1, x+1, y+1, up, down)"
    return [
        ([0, 1, 7], ValueError, f"copy 2: {moves}, got 7"),
        (np.array([0, -1, 2], dtype=np.int8), ValueError, f"copy 1: {moves}, got -1"),
        ([0, 1, 2**70], ValueError, f"copy 2: {moves}, got {2**70}"),
        ([0.0, 1.0, 2.0], ActionTypeError, "copy 0: action must be an integer, got 0.0 (float)"),
        ([0, 1, None], ActionTypeError, "copy 2: action must be an integer, got None"),
        ([True, False, True], ActionTypeError, "copy 0: action must be an integer, got the bool"),
        (["1", "2", "3"], ActionTypeError, "copy 0: action must be an integer, got '1' (str)"),
        ([0, 1], ValueError, "shape (3,) (one per copy), got (2,)"),
        (np.zeros((3, 1), dtype=int), ValueError, "got (3, 1)"),
        (2, ValueError, "got ()"),
    ]


@pytest.mark.parametrize(("actions", "error", "message"), _bad_inputs())
def test_bad_actions_get_the_one_site_errors_naming_the_copy(actions, error, message):
    env = PaperVectorEnv(3)
    env.reset(seed=0)
    before = [a.copy() for a in env.state]
    with pytest.raises(error, match=re.escape(message)):
        env.step(actions)
    assert all(np.array_equal(a, b) for a, b in zip(before, env.state, strict=True))


def test_the_one_site_message_is_part_of_the_vector_message():
    one = PaperAssemblyEnv()
    one.reset(seed=0)
    with pytest.raises(ValueError) as single:
        one.step(7)
    env = PaperVectorEnv(2)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="copy 1") as vector:
        env.step([0, 7])
    assert str(single.value) in str(vector.value)


@pytest.mark.parametrize(
    ("call", "error", "message"),
    [
        (lambda: PaperVectorEnv(2).step([0, 0]), RuntimeError, r"step\(\) called before reset"),
        (lambda: PaperVectorEnv(2).action_masks(), RuntimeError, "call reset"),
        (lambda: PaperVectorEnv(0), ValueError, "num_envs must be at least 1"),
        (lambda: PaperVectorEnv(2.5), ActionTypeError, "num_envs must be an integer"),
        (lambda: PaperVectorEnv(2, config="E9S9"), ValueError, "unknown paper configuration"),
        (lambda: PaperVectorEnv(2).generator(2), IndexError, "copy 2 out of range 0..1"),
    ],
)
def test_bad_construction_and_calls(call, error, message):
    with pytest.raises(error, match=message):
        call()


def test_unmodelled_scenarios_are_refused():
    with pytest.raises(ValueError, match="crane reach"):
        compile_site(multicrane.load_scenario("towers-3c"))


def test_a_start_that_cannot_be_drawn_raises_the_scenario_error():
    env = PaperVectorEnv(2, config="E1S3")
    env.site.prebuilt_on[:] = -1  # two pre-built components that may only stand on target 1
    env.site.prebuilt_on[0:2, 0] = 1
    env.site.prebuilt[0] = True
    with pytest.raises(ScenarioError, match="copy 0: no start found"):
        env.reset(seed=0)


def test_masks_allow_all_six_without_the_option_and_the_generator_goes_on():
    env = PaperVectorEnv(4, config="E2S2")
    env.reset(seed=1)
    assert env.action_masks().dtype == np.int8 and env.action_masks().all()
    g = env.generator(3)
    assert g.bit_generator.state == env.generator(3).bit_generator.state
