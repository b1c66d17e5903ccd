"""A greedy team stuck waiting: ``WaitLoop`` notices it and ``break_wait`` starts the one task
the policy prefers most (``multicrane.training.model_policy``).

A trained policy once assembled 25 of 26 components of frame2-3c and then let every crane wait
until the step limit: the same observations gave the same waits. These tests pin down when
the loop is seen (all waits, the clock moved, identical observations), what replaces it (the
best allowed task of any crane, never a blocked one), that the scores the break reads are the
ones the greedy choice comes from, and that ``break_waits=False`` keeps the old behaviour.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("sb3_contrib")

from sb3_contrib import MaskablePPO  # noqa: E402

from multicrane.core.codes import WAIT  # noqa: E402
from multicrane.envs.crane_env import MultiCraneEnv  # noqa: E402
from multicrane.episodes.rollout import run_episode  # noqa: E402
from multicrane.training.model_policy import (  # noqa: E402
    SetModelPolicy,
    SharedModelPolicy,
    WaitLoop,
    break_wait,
)
from multicrane.training.set_obs import SetLimits  # noqa: E402
from multicrane.training.set_policy import BLOCKED  # noqa: E402
from multicrane.training.set_training import make_set_model, set_hyperparameters  # noqa: E402
from multicrane.training.set_vec_env import SetVecEnv  # noqa: E402

pytestmark = pytest.mark.usefixtures("one_torch_thread")

B = BLOCKED


@pytest.mark.parametrize(
    "scores, wait, expected",
    [
        # the best non-wait action over all rows; a high wait score does not count
        ([[0.0, B, 2.0], [5.0, 1.0, B]], 0, [2, 0]),
        ([[0.0, 1.0, B], [0.0, B, 3.0]], 0, [0, 2]),
        # a row that may only wait (a busy crane) is never given a task
        ([[9.0, B, B], [0.0, -4.0, B]], 0, [0, 1]),
        # nothing allowed to anyone: the waits stay
        ([[1.0, B, B], [2.0, B, B]], 0, [0, 0]),
        # -inf also means not allowed
        ([[0.0, -np.inf, -7.0]], 0, [2]),
        # the motion level waits with action 6
        ([[3.0, B, B, B, B, B, 9.0], [B, B, B, B, 1.0, B, 0.0]], 6, [0, 6]),
    ],
)
def test_break_wait_takes_the_best_allowed_action_but_a_wait(scores, wait, expected):
    assert break_wait(np.array(scores), wait).tolist() == expected


def _set_model(env):
    limits = SetLimits.of(env.observation_layout)
    venv = SetVecEnv(lambda i: MultiCraneEnv("e2s2", n_cranes=2, decisions="task"), 1, limits)
    hp = set_hyperparameters({"n_steps": 8, "batch_size": 8})
    return make_set_model(venv, 0, hp, None)


@pytest.fixture(scope="module")
def e2s2():
    env = MultiCraneEnv("e2s2", n_cranes=2, decisions="task", max_steps=150)
    return env, _set_model(env)


def _batch(obs):
    return np.stack([o["observation"] for o in obs.values()])


@pytest.mark.parametrize("decisions", ["task", "motion"])
def test_wait_loop_needs_all_waits_a_moved_clock_and_the_same_observations(decisions):
    env = MultiCraneEnv("e2s2", n_cranes=2, decisions=decisions)
    wait = env.wait_action
    assert wait == (0 if decisions == "task" else WAIT)
    waits = np.full(2, wait)
    loop = WaitLoop(env)
    obs, _ = env.reset(seed=0)
    batch = _batch(obs)
    assert not loop.stuck(batch)  # nothing remembered yet
    loop.remember(batch, waits)
    assert not loop.stuck(batch)  # the clock has not moved
    obs, *_ = env.step(dict.fromkeys(env.agents, wait))
    clock = env.observation_layout.clock if decisions == "motion" else slice(0, 0)
    changed = np.flatnonzero(np.any(_batch(obs) != batch, axis=0)).tolist()
    assert changed == list(range(clock.start, clock.stop))  # waiting moved the clock only
    assert loop.stuck(_batch(obs))
    assert not loop.stuck(_batch(obs) * 0.5)  # other observations
    other = (wait + 1) % env.action_space(env.agents[0]).n
    loop.remember(_batch(obs), np.array([wait, other]))
    obs, *_ = env.step(dict.fromkeys(env.agents, wait))
    assert not loop.stuck(_batch(obs))  # the last joint action was not all waits
    loop.remember(batch, waits)
    obs, _ = env.reset(seed=0)
    assert not loop.stuck(_batch(obs))  # a new episode: the clock went back


class _Waiter(SetModelPolicy):
    """A set policy whose greedy choice is always to wait (the worst case of the loop): its
    wait score beats everything; the others keep the network's order (for the break)."""

    def _scores(self, batch, masks):
        scores = super()._scores(batch, masks)
        scores[:, 0] = 1e9
        return scores


def test_a_team_that_always_waits_still_finishes_with_allowed_tasks_only(e2s2):
    env, model = e2s2
    stuck = run_episode(env, _Waiter(model, env, break_waits=False), seed=1)
    assert not stuck["success"] and stuck["steps"] == 150  # it waits to the step limit

    policy = _Waiter(model, env)
    obs, _ = env.reset(seed=1)
    rounds = 0
    while env.agents:
        acts = policy(obs)
        for agent, action in acts.items():
            assert obs[agent]["action_mask"][action], f"illegal action {action}"
        assert sum(a != 0 for a in acts.values()) <= 1  # the break starts one task at a time
        obs, *_ = env.step(acts)
        rounds += 1
    done = run_episode(env, _Waiter(model, env), seed=1)
    assert done["success"], "the break should carry every component in"
    assert done["decision_rounds"] == rounds  # same seed, same episode


class _Spaces(gym.Env):
    """Only the spaces of one crane's vector: enough to build an untrained MLP model."""

    def __init__(self, env):
        agent = env.possible_agents[0]
        self.observation_space = env.observation_space(agent)["observation"]
        self.action_space = env.action_space(agent)


def test_the_break_reads_the_scores_the_greedy_choice_comes_from(e2s2):
    env, model = e2s2
    set_policy = SetModelPolicy(model, env)
    mlp_env = MultiCraneEnv("e2s2", n_cranes=2)
    mlp = MaskablePPO("MlpPolicy", _Spaces(mlp_env), n_steps=8, batch_size=8, seed=0)
    shared = SharedModelPolicy(mlp, mlp_env)
    for policy, env_ in ((set_policy, env), (shared, mlp_env)):
        obs, _ = env_.reset(seed=2)
        for _ in range(5):
            batch, masks = policy._inputs(obs)
            scores = policy._scores(batch, masks)
            greedy = policy._act(batch, masks)
            assert np.array_equal(scores.argmax(-1), greedy)
            assert np.all(scores[~masks] <= BLOCKED)  # nothing blocked looks allowed
            obs, *_ = env_.step(policy(obs))
            if not env_.agents:
                break
