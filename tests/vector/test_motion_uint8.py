"""``MotionVectorEnv(obs_dtype=np.uint8)``: the float32 observations in whole numbers."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from multicrane.scenario.loader import load_scenario
from multicrane.vector import bench
from multicrane.vector.motion_site import STEP_SCALE
from multicrane.vector.motion_vector_env import MotionVectorEnv
from multicrane.vector.pcg64 import state_of


def _same_values(whole: np.ndarray, exact: np.ndarray, env: MotionVectorEnv) -> None:
    """``whole / obs_scale`` is ``exact`` bit for bit, but for the step fraction: rounded
    down to 1/255."""
    step = env.site.crane_start + 8
    decoded = whole.astype(np.float32) / env.obs_scale
    others = np.arange(whole.shape[-1]) != step
    assert np.array_equal(decoded[..., others], exact[..., others])
    error = exact[..., step].astype(np.float64) - whole[..., step] / STEP_SCALE
    assert (error > -1e-6).all() and (error < 1 / STEP_SCALE).all()


@pytest.mark.long  # the uint8 kernels compile apart from the float32 ones: about 2 min of CPU
@pytest.mark.parametrize(
    ("scenario", "cranes", "events"), [("e2s2", 2, None), ("hall-4c", 4, None), ("e4s3", 3, "high")]
)
def test_uint8_observations_are_the_float32_ones_in_whole_numbers(scenario, cranes, events):
    options = {"n_cranes": cranes, "events": events, "max_steps": 90}
    exact = MotionVectorEnv(5, scenario, **options)
    whole = MotionVectorEnv(5, scenario, obs_dtype=np.uint8, **options)
    assert whole.buffers.obs.dtype == np.uint8 and whole.obs_scale.shape == (exact.site.obs_size,)
    assert whole.single_observation_space.contains(np.zeros(exact.site.obs_size, np.uint8))
    obs_exact, _ = exact.reset(seed=4)
    obs_whole, _ = whole.reset(seed=4)
    _same_values(obs_whole, obs_exact, whole)
    rng = state_of(np.random.default_rng(4))[None].copy()
    actions = np.zeros((5, cranes), dtype=np.int64)
    ended = 0
    for _ in range(200):
        assert np.array_equal(whole.buffers.masks, exact.buffers.masks)
        bench.sample_legal(rng, exact.buffers.masks, actions)
        *out_exact, infos_exact = exact.step(actions)
        *out_whole, infos_whole = whole.step(actions)
        _same_values(out_whole[0], out_exact[0], whole)
        for a, b in zip(out_whole[1:], out_exact[1:], strict=True):
            assert np.array_equal(a, b)
        done = infos_exact["_final_obs"]
        assert np.array_equal(infos_whole["_final_obs"], done)
        _same_values(infos_whole["final_obs"][done], infos_exact["final_obs"][done], whole)
        ended += done.sum()
    assert ended  # episodes ended: final observations and autoresets compared


def test_uint8_refuses_a_scale_over_a_byte():
    scenario = load_scenario("e2s2")
    far = dataclasses.replace(scenario, reward=dataclasses.replace(scenario.reward, move_limit=300))
    with pytest.raises(ValueError, match="move limit is 300"):
        MotionVectorEnv(1, far, n_cranes=2, obs_dtype=np.uint8)
    MotionVectorEnv(1, far, n_cranes=2)  # float32 takes any
    with pytest.raises(ValueError, match="obs_dtype must be float32 or uint8"):
        MotionVectorEnv(1, "e2s2", obs_dtype=np.float64)
