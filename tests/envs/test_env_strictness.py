"""The environments' boundary (issue 20): integer actions only, masks the caller cannot
change, and a clear "call reset() first" before the first reset.

Before the fix ``int()`` turned the action 2.7 into 2, strict mode checked the very array
handed to the caller (who could set a zero to one and pass an illegal action), and
``render()``/``state()``/``action_masks()`` before ``reset()`` raised AttributeError or
IndexError.
"""

from __future__ import annotations

import numpy as np
import pytest

import multicrane
from multicrane.envs.boundary import as_integer
from multicrane.envs.paper_env import PaperAssemblyEnv

NOT_INTEGERS = [2.7, 2.0, True, np.bool_(False), "2", None, [2], np.float32(1.0)]
INTEGERS = [2, np.int64(2), np.int8(2), np.uint16(2), np.array(2)]


@pytest.mark.parametrize("value", INTEGERS, ids=repr)
def test_integers_pass(value):
    assert as_integer(value, "x") == 2


@pytest.mark.parametrize("value", NOT_INTEGERS, ids=repr)
def test_multi_agent_env_refuses_non_integer_actions(value):
    env = multicrane.parallel_env("e2s2", n_cranes=2)
    env.reset(seed=0)
    actions = {"crane_0": 6, "crane_1": value}
    with pytest.raises(TypeError, match=r"crane_1.*must be an integer") as info:
        env.step(actions)
    assert repr(value) in str(info.value)
    assert isinstance(info.value, ValueError)  # old callers caught ValueError
    assert env.sim.state.step_count == 0  # nothing happened


@pytest.mark.parametrize("value", NOT_INTEGERS, ids=repr)
def test_paper_env_refuses_non_integer_actions(value):
    env = PaperAssemblyEnv("E1S1")
    env.reset(seed=0)
    with pytest.raises(TypeError, match="must be an integer"):
        env.step(value)


def test_n_cranes_must_be_an_integer_in_range():
    with pytest.raises(TypeError, match=r"n_cranes must be an integer, got 2\.7"):
        multicrane.parallel_env("e2s2", n_cranes=2.7)
    with pytest.raises(ValueError, match="MAX_CRANES"):
        multicrane.parallel_env("e2s2", n_cranes=100_000_000)
    assert multicrane.parallel_env("e2s2", n_cranes=np.int64(3)).sim.n_cranes == 3


def test_max_steps_must_be_an_integer():
    with pytest.raises(TypeError, match="max_steps"):
        multicrane.parallel_env("e2s2", max_steps=2.7)
    assert multicrane.parallel_env("e2s2", max_steps=np.int64(7)).step_limit == 7


def test_strict_mode_checks_its_own_mask():
    env = multicrane.parallel_env("e2s2", n_cranes=1, strict=True, info_mask=True)
    obs, infos = env.reset(seed=0)
    mask = obs["crane_0"]["action_mask"]
    illegal = int(np.flatnonzero(mask == 0)[0])
    # The caller scribbles on every mask it was handed.
    mask[:] = 1
    infos["crane_0"]["action_mask"][:] = 1
    env.action_masks()["crane_0"][:] = 1
    assert env.action_masks()["crane_0"][illegal] == 0
    with pytest.raises(ValueError, match="illegal action"):
        env.step({"crane_0": illegal})


@pytest.mark.parametrize("method", ["render", "state", "action_masks"])
def test_multi_agent_env_before_reset(method):
    env = multicrane.parallel_env("e2s2", render_mode="ansi")
    with pytest.raises(RuntimeError, match=r"call reset\(\) first"):
        getattr(env, method)()
    with pytest.raises(RuntimeError, match=r"reset\(\) first"):
        env.step({"crane_0": 6})


@pytest.mark.parametrize("method", ["render", "action_masks"])
def test_paper_env_before_reset(method):
    env = PaperAssemblyEnv("E1S1", render_mode="ansi", mask_blocked_moves=True)
    with pytest.raises(RuntimeError, match=r"call reset\(\) first"):
        getattr(env, method)()
    with pytest.raises(RuntimeError, match=r"call reset\(\) first"):
        env.step(0)
