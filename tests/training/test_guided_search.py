"""A look-ahead guided by a trained model (``lookahead:guide=RUN``): the model's scores rank
the first idle crane's candidates, its own joint action is tried too, and the search plays
whole episodes legally from the command line's spec."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import one_torch_thread  # noqa: F401 (fixture)

import policies
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.episodes.rollout import run_episode
from multicrane.training import TrainConfig, train
from multicrane.training.model_policy import load_run
from multicrane.training.set_policy import BLOCKED

pytestmark = pytest.mark.usefixtures("one_torch_thread")


@pytest.fixture(scope="module", params=[False, True], ids=["plain", "planner-hint"])
def run_dir(tmp_path_factory, request):
    """A set policy after a few PPO steps (its weights are what they are: a guide need not
    be good to be followed); with the planner's hint, the guide asks the planner's rule
    after the search's own planner has probed the round (``TaskBook.trial``'s copy)."""
    path = tmp_path_factory.mktemp("guide") / "e3s2-s0"
    cfg = TrainConfig("e3s2", paper=False, n_cranes=2, decisions="task", algo="maskable_ppo",
                      policy="set", planner_hint=request.param,
                      reward="makespan", shaping=0.0, n_envs=2, total_steps=32,
                      eval_every=0, eval_episodes=1, checkpoint_every=0,
                      hyperparams={"n_steps": 16, "batch_size": 16, "n_epochs": 1})  # fmt: skip
    train(cfg, path, log=lambda *a: None)
    return path


def _env() -> MultiCraneEnv:
    return MultiCraneEnv("e3s2", n_cranes=2, decisions="task", reward="makespan")


def test_the_models_scores_are_one_row_per_crane_blocked_where_masked(run_dir):
    env = _env()
    guide = policies.factory(str(run_dir))(env, 0)
    observations, _ = env.reset(seed=1)
    scores = guide.scores(observations)
    masks = np.stack([o["action_mask"] for o in observations.values()]).astype(bool)
    assert scores.shape == masks.shape
    assert np.all(scores[~masks] <= BLOCKED) and np.all(scores[masks] > BLOCKED)


def test_the_guided_search_tries_the_models_choices(run_dir):
    env = _env()
    search = policies.factory(f"lookahead:candidates=2,guide={run_dir}")(env, 1)
    observations, _ = env.reset(seed=1)
    own = search.guide(observations)
    scores = search.guide.scores(observations)
    search(observations)
    agent, values = search.values
    row = list(observations).index(agent)
    best = [int(a) for a in np.argsort(-scores[row], kind="stable") if a > 0][:2]
    assert set(best) <= set(values) and own[agent] in values


def test_the_guided_search_finishes_an_episode_from_the_spec(run_dir):
    env = _env()
    made = policies.factory(f"lookahead:guide={run_dir}")
    assert made.label == f"lookahead:guide={run_dir}"
    model, _ = load_run(run_dir)
    assert made.options["guide"].model is not None and model is not None
    search = made(env, 2)
    episode = run_episode(env, search, seed=2)
    assert episode["success"] and search.rollouts > 0


def test_a_trained_base_finishes_the_copies_and_the_search_is_no_later_than_it(run_dir):
    """``lookahead:base=RUN``: the rollouts finish with the trained policy (greedy, claims as
    deployed) instead of the prioritized planner; candidates 0 leaves only the base's own
    joint action and waiting, so the search plays no later than the policy alone."""
    env = _env()
    made = policies.factory(f"lookahead:candidates=0,base={run_dir}")
    alone = policies.factory(str(run_dir))
    for seed in (0, 1, 2):
        search = made(env, seed)
        searched = run_episode(env, search, seed=seed, record=True)
        plain = run_episode(env, alone(env, seed), seed=seed)
        assert searched["success"] and search.rollouts > 0
        assert searched["steps"] <= plain["steps"]
    # The base is the trained policy: with it as the planner, the round's proposal is its own.
    observations, _ = env.reset(seed=4)
    search = made(env, 4)
    assert search.base(env)(observations) == alone(env, 4)(observations)


def test_a_base_must_be_a_trained_set_policy(tmp_path):
    with pytest.raises(policies.PolicyError, match="base='greedy' is not a trained model"):
        policies.factory("lookahead:base=greedy")
    with pytest.raises(policies.PolicyError, match="no such run directory"):
        policies.factory(f"lookahead:base={tmp_path / 'none'}")
