"""``MotionVectorEnv``'s boundary: shapes, seeds, refusals, errors naming the copy, the bench."""

from __future__ import annotations

import numpy as np
import pytest

from multicrane.core.codes import CLAIM_BASE, WAIT
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.vector import bench
from multicrane.vector.motion_vector_env import MotionVectorEnv
from multicrane.vector.pcg64 import state_of


def test_shapes_and_dtypes():
    env = MotionVectorEnv(3, "e2s2", n_cranes=2)
    obs, infos = env.reset(seed=0)
    ref = MultiCraneEnv("e2s2", n_cranes=2, obs_format="flat")
    D, A = ref.observation_layout.size, ref.n_actions
    assert obs.shape == (3, 2, D) and obs.dtype == np.float32
    assert env.action_masks().shape == (3, 2, A) and env.action_masks().dtype == np.int8
    obs, rewards, terms, truncs, infos = env.step(np.full((3, 2), WAIT))
    assert rewards.shape == terms.shape == truncs.shape == (3, 2)
    assert infos["event_counts"].shape == (3, 2, 11) and infos["reward_term"].shape == (3, 2)


def test_an_int_seed_gives_each_copy_a_child_of_one_seed_sequence():
    env = MotionVectorEnv(4, "e1s1", n_cranes=1)
    env.reset(seed=7)
    ref = MultiCraneEnv("e1s1", n_cranes=1, obs_format="flat")
    for b, child in enumerate(np.random.SeedSequence(7).spawn(4)):
        g = np.random.Generator(np.random.PCG64(child))
        ref._rng = g  # the one-site env's episode generator, as reset(seed) would set it
        obs, _ = ref.reset()
        assert np.array_equal(env.buffers.obs[b, 0], obs["crane_0"])
        assert np.array_equal(env.state.rng[b], state_of(g))
        assert np.array_equal(state_of(env.generator(b)), state_of(g))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [({"events": "medium"}, "events level"), ({"reward": "fast"}, "reward must be"),
     ({"n_cranes": 0}, "n_cranes"), ({"num_envs": 0}, "num_envs")],  # fmt: skip
)
def test_refusals(kwargs, message):
    options = {"num_envs": 1, "scenario": "e2s2", **kwargs}
    with pytest.raises(ValueError, match=message):
        MotionVectorEnv(**options)


def test_bad_actions_name_the_copy_and_crane():
    env = MotionVectorEnv(2, "e2s2", n_cranes=2, strict=True)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros((2, 2), dtype=np.int64))
    env.reset(seed=1)
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(2, dtype=np.int64))
    bad = np.full((2, 2), WAIT)
    bad[1, 0] = CLAIM_BASE + 3
    with pytest.raises(ValueError, match="copy 1: crane_0 sent action 11, outside 0..10"):
        env.step(bad)
    with pytest.raises(TypeError, match="copy 0: the action of crane_1"):
        env.step(np.array([[6, 2.5], [6, 6]], dtype=object))
    masked = np.full((2, 2), WAIT)
    masked[0, 1] = 0  # a move with nothing held
    with pytest.raises(ValueError, match=r"copy 0: crane_1 sent illegal action 0 \(x-1\)"):
        env.step(masked)


def test_the_legal_sampler_draws_only_legal_actions():
    env = MotionVectorEnv(8, "e4s3", n_cranes=3)
    env.reset(seed=2)
    rng = state_of(np.random.default_rng(0))[None].copy()
    actions = np.zeros((8, 3), dtype=np.int64)
    for _ in range(50):
        bench.sample_legal(rng, env.buffers.masks, actions)
        masks = env.action_masks()
        assert np.take_along_axis(masks, actions[..., None], axis=2).all()
        env.step(actions)


def test_motion_measurements():
    assert bench.motion_steps_per_second("e2s2", 2, 16, seconds=0.05) > 0
    assert bench.motion_bytes_per_copy("e2s2", 2, 8) > 0
