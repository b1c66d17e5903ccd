"""``get_state``/``set_state`` of the vector envs: a restored env goes on exactly as the one
it was taken from (observations, masks, rewards, flags, infos and generators, over autoresets
and, in the motion mode, site events whose tables grow after the snapshot); a snapshot that
does not fit is refused naming the array."""

from __future__ import annotations

import numpy as np
import pytest

from multicrane.vector.motion_vector_env import MotionVectorEnv
from multicrane.vector.paper_vector_env import PaperVectorEnv
from multicrane.vector.task_vector_env import TaskVectorEnv


def _legal_actions(rng: np.random.Generator, masks: np.ndarray) -> np.ndarray:
    """One legal action per row of ``masks`` (the last axis), drawn by ``rng``."""
    rows = masks.reshape(-1, masks.shape[-1]).astype(bool)
    picks = [rng.choice(np.flatnonzero(row)) for row in rows]
    return np.array(picks).reshape(masks.shape[:-1])


def _play(env, actions_rng: np.random.Generator, steps: int) -> list:
    seen = []
    for _ in range(steps):
        obs, rew, term, trunc, infos = env.step(_legal_actions(actions_rng, env.action_masks()))
        seen.append((obs.copy(), rew.copy(), term.copy(), trunc.copy(), env.action_masks(),
                     {k: np.array(v).copy() for k, v in infos.items()}))  # fmt: skip
    return seen


def _assert_same(a: list, b: list) -> None:
    assert len(a) == len(b)
    for step, (x, y) in enumerate(zip(a, b, strict=True)):
        for part, (u, v) in enumerate(zip(x[:5], y[:5], strict=True)):
            np.testing.assert_array_equal(u, v, err_msg=f"step {step}, output {part}")
        assert x[5].keys() == y[5].keys()
        for key in x[5]:
            np.testing.assert_array_equal(x[5][key], y[5][key], err_msg=f"step {step}, {key}")


@pytest.mark.parametrize(
    "make",
    [
        lambda: PaperVectorEnv(5, config="E1S1"),
        lambda: MotionVectorEnv(3, scenario="e2s3", n_cranes=2, max_steps=60, events="high"),
        lambda: TaskVectorEnv(3, scenario="towers-3c", max_steps=120),
    ],
    ids=["paper", "motion-events", "task"],
)
def test_a_restored_env_goes_on_as_the_original(make):
    env = make()
    env.reset(seed=11)
    _play(env, np.random.default_rng(0), 25)
    snapshot = env.get_state()
    first = _play(env, np.random.default_rng(1), 150)
    ends = sum(int(np.any(s[2]) or np.any(s[3])) for s in first)
    assert ends > 0, "the run must cross autoresets"
    other = make()
    other.reset(seed=99)  # another episode altogether until the snapshot is restored
    other.set_state(snapshot)
    _assert_same(first, _play(other, np.random.default_rng(1), 150))
    env.set_state(snapshot)  # and the original returns to it too
    _assert_same(first, _play(env, np.random.default_rng(1), 150))


def test_a_snapshot_that_does_not_fit_is_refused():
    env = PaperVectorEnv(4, config="E1S1")
    env.reset(seed=0)
    other = PaperVectorEnv(3, config="E1S1")
    other.reset(seed=0)
    with pytest.raises(ValueError, match=r"buffers\.obs"):
        other.set_state(env.get_state())
    snapshot = env.get_state()
    snapshot["state"] = snapshot["state"][:-1]
    with pytest.raises(ValueError, match="state: .* arrays, expected"):
        env.set_state(snapshot)


def test_a_restored_task_env_proposes_as_the_original():
    """The task env's snapshot holds its task book and carrier too: the compiled rule, whose
    plans ride in them, plays the same rounds after a restore."""
    env = TaskVectorEnv(2, scenario="hall-4c", n_cranes=4)
    env.reset(seed=5)
    for _ in range(12):
        env.step(env.propose())
    snapshot = env.get_state()
    first = [env.step(env.propose())[0].copy() for _ in range(60)]
    other = TaskVectorEnv(2, scenario="hall-4c", n_cranes=4)
    other.reset(seed=8)
    other.propose()
    other.set_state(snapshot)
    again = [other.step(other.propose())[0].copy() for _ in range(60)]
    assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))
