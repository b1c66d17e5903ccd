"""``TaskVectorEnv``'s boundary: shapes, seeds, refusals, errors naming the copy, the rule."""

from __future__ import annotations

import numpy as np
import pytest

from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.vector.pcg64 import state_of
from multicrane.vector.task_vector_env import TaskVectorEnv


def test_shapes_dtypes_and_infos():
    env = TaskVectorEnv(3, "towers-3c")
    obs, infos = env.reset(seed=0)
    ref = MultiCraneEnv("towers-3c", decisions="task", obs_format="flat")
    D, A, N = ref.observation_layout.size, ref.n_actions, ref.sim.n_cranes
    assert obs.shape == (3, N, D) and obs.dtype == np.float32
    assert env.single_observation_space == ref.observation_space("crane_0")
    assert env.action_masks().shape == (3, N, A) and env.action_masks().dtype == np.int8
    obs, rewards, terms, truncs, infos = env.step(env.propose())
    assert rewards.shape == terms.shape == truncs.shape == (3, N)
    assert infos["event_counts"].shape == (3, N, 11) and infos["reward_term"].shape == (3, N)
    assert infos["task_event_counts"].shape == (3, N, 5)
    assert infos["elapsed"].shape == infos["crane_steps"].shape == (3,)
    assert (infos["elapsed"] >= 1).all()


def test_an_int_seed_gives_each_copy_a_child_of_one_seed_sequence():
    env = TaskVectorEnv(3, "hall-4c", 2)
    env.reset(seed=11)
    ref = MultiCraneEnv("hall-4c", 2, decisions="task", obs_format="flat")
    for b, child in enumerate(np.random.SeedSequence(11).spawn(3)):
        g = np.random.Generator(np.random.PCG64(child))
        ref._rng = g  # the one-site env's episode generator, as reset(seed) would set it
        obs, _ = ref.reset()
        assert np.array_equal(env.buffers.obs[b, 0], obs["crane_0"])
        assert np.array_equal(env.state.rng[b], state_of(g))


def test_same_seeds_same_rounds_and_copies_on_request():
    runs = []
    for _ in range(2):
        env = TaskVectorEnv(2, "frame2-3c", copy=True)
        out = [env.reset(seed=[4, 5])[0]]
        for _ in range(20):
            out.append(env.step(env.propose())[0])
        runs.append(out)
    assert all(np.array_equal(a, b) for a, b in zip(*runs, strict=True))
    assert runs[0][1] is not runs[0][2]  # copy=True: fresh arrays


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [({"events": "high"}, "site events are not modelled"), ({"reward": "fast"}, "reward must"),
     ({"n_cranes": 0}, "n_cranes"), ({"num_envs": 0}, "num_envs"),
     ({"task_patience": 0}, "task_patience")],  # fmt: skip
)
def test_refusals(kwargs, message):
    with pytest.raises(ValueError, match=message):
        TaskVectorEnv(**{"num_envs": 1, "scenario": "hall-4c", **kwargs})


def test_errors_name_the_copy_and_the_crane():
    env = TaskVectorEnv(2, "e2s2", 2, strict=True)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros((2, 2), dtype=np.int64))
    with pytest.raises(RuntimeError, match="reset"):
        env.propose()
    env.reset(seed=1)
    with pytest.raises(ValueError, match="shape"):
        env.step(np.zeros(2, dtype=np.int64))
    bad = np.zeros((2, 2), dtype=np.int64)
    bad[1, 0] = env.n_actions
    with pytest.raises(ValueError, match=f"copy 1: crane_0 sent action {env.n_actions}"):
        env.step(bad)
    masks = env.action_masks()
    b, k, a = (int(v) for v in np.argwhere(masks == 0)[0])
    bad = np.zeros((2, 2), dtype=np.int64)
    bad[b, k] = a
    with pytest.raises(ValueError, match=f"copy {b}: crane_{k} sent illegal action {a}"):
        env.step(bad)
    with pytest.raises(ValueError, match="copy 0: the action of crane_0 must be an integer"):
        env.step(np.array([[0, 1.5], [0, 0]]))
    loose = TaskVectorEnv(2, "e2s2", 2)
    loose.reset(seed=1)
    bad[1, 1] = -1
    with pytest.raises(ValueError, match="copy 1: crane_1 sent action -1"):
        loose.step(bad)  # the kernel's check: nothing stepped
    assert (loose.buffers.elapsed == 0).all()


def test_the_rule_ranks_as_asked():
    """The first tasks go to the components first in the list order asked: the scenario's,
    or one given (the columns of hall-4c are claimable at the start, the beams wait)."""
    picked = []
    for order in (None, list(reversed(range(29)))):
        env = TaskVectorEnv(1, "hall-4c", 4)
        env.reset(seed=2)
        actions = env.propose(order=order)[0]
        picked.append({int(env.task_site.task_comp[a - 1]) for a in actions if a > 0})
    assert min(picked[0]) == 0 and max(picked[1]) == 11
    with pytest.raises(ValueError, match="rank must be"):
        env.propose(rank="fastest")
