"""The motion kernels' incremental observations: always those written from scratch."""

from __future__ import annotations

import numpy as np
import pytest

from multicrane.vector import bench
from multicrane.vector.motion_observe import observe_reset
from multicrane.vector.motion_rules import write_masks
from multicrane.vector.motion_vector_env import MotionVectorEnv
from multicrane.vector.pcg64 import state_of


def _from_scratch(env: MotionVectorEnv):
    """Observations, claimability and masks rebuilt from the state alone, on copies."""
    state = type(env.state)(*(a.copy() for a in env.state))
    buffers = type(env.buffers)(*(a.copy() for a in env.buffers))
    for b in range(env.num_envs):
        observe_reset(env.site, state, buffers, b)
        write_masks(env.site, state, buffers.masks, b)
    return buffers.obs, state.claimable, buffers.masks


@pytest.mark.parametrize(("scenario", "cranes"), [("hall-4c", 4), ("e2s2", 2)])
def test_the_observations_written_where_they_changed_are_those_from_scratch(scenario, cranes):
    env = MotionVectorEnv(6, scenario, n_cranes=cranes)
    env.reset(seed=3)
    rng = state_of(np.random.default_rng(3))[None].copy()
    actions = np.zeros((env.num_envs, env.n_cranes), dtype=np.int64)
    for step in range(400):
        bench.sample_legal(rng, env.buffers.masks, actions)
        env.step(actions)
        if step % 40 == 39:
            obs, claimable, masks = _from_scratch(env)
            assert np.array_equal(env.buffers.obs, obs)
            assert np.array_equal(env.state.claimable, claimable)
            assert np.array_equal(env.buffers.masks, masks)
