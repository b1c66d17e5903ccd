"""Exclusive claims in PPO's rollouts (``multicrane.training.claims``): the crane rows of a
copy choose as the deployed policy does, and PPO's buffer keeps the masks they chose under."""

from __future__ import annotations

import numpy as np
import pytest
import torch as th
from conftest import one_torch_thread  # noqa: F401 (fixture)

import multicrane
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.scenario.named_sets import resolve_set
from multicrane.tasks.task_list import exclusive_round, task_list
from multicrane.training import TrainConfig
from multicrane.training.claims import claim_in_turn
from multicrane.training.set_obs import SetLimits
from multicrane.training.set_training import make_set_model, make_set_vec_env, set_hyperparameters
from multicrane.training.set_vec_env import SetVecEnv

pytestmark = pytest.mark.usefixtures("one_torch_thread")


def _venv(name: str, cranes: int, copies: int = 3, limits: SetLimits | None = None):
    make = lambda i: MultiCraneEnv(name, n_cranes=cranes, decisions="task")  # noqa: E731
    return SetVecEnv(make, copies, limits or SetLimits.of(make(0).observation_layout))


def _sites():
    return [(name, name) for name in multicrane.scenario_names()] + list(
        resolve_set("set:test-small")
    )[:10]


@pytest.mark.parametrize(("name", "site"), _sites()[:12] + _sites()[-3:])
def test_a_task_s_target_nodes_name_its_target(name, site):
    # The claims read a task's target from its six target-node columns: on every site two
    # tasks have the same nodes exactly when they have the same target.
    env = MultiCraneEnv(site, decisions="task")
    obs, _ = env.reset(seed=0)
    tasks = env.observation_layout.split(next(iter(obs.values()))["observation"])["tasks"]
    nodes = tasks[:, 1:7]
    same_nodes = (nodes[:, None, :] == nodes[None, :, :]).all(-1)
    target = task_list(env).target
    assert np.array_equal(same_nodes, target[:, None] == target[None, :])


def _best(scores: np.ndarray):
    return lambda k, mask: int(np.argmax(np.where(mask, scores[k], -np.inf)))


@pytest.mark.parametrize(("name", "cranes"), [("hall-4c", 4), ("e3s3", 2), ("frame2-3c", 3)])
def test_claims_in_turn_are_the_deployed_policy_s_claims(name, cranes):
    # Random scores over many rounds of three copies: the greedy claims are exactly those of
    # ``exclusive_round`` with the site's own conflicts, and so are the masks each row saw.
    venv = _venv(name, cranes, limits=SetLimits(32, 4, 320))
    venv.seed(5)
    obs = venv.reset()
    rng = np.random.default_rng(0)
    rounds_with_two = 0
    for _ in range(40):
        masks = venv.action_masks()
        scores = rng.normal(size=masks.shape).astype(np.float32)
        actions, seen = claim_in_turn(th.as_tensor(obs), th.as_tensor(scores),
                                      th.as_tensor(masks), venv.limits, 4, True)  # fmt: skip
        for c, env in enumerate(venv.envs):
            block = slice(4 * c, 4 * c + 4)
            want_masks, want = exclusive_round(masks[block], task_list(env), _best(scores[block]))
            assert actions[block].tolist() == want.tolist()
            assert np.array_equal(seen[block].numpy(), want_masks)
            rounds_with_two += int((masks[block].sum(1) > 1).sum() > 1)
        obs, *_ = venv.step(actions.numpy())
    assert rounds_with_two > 0  # some rounds had more than one crane to claim


def test_sampled_claims_never_conflict():
    venv = _venv("hall-4c", 4, copies=2)
    venv.seed(1)
    obs = th.as_tensor(venv.reset())
    masks = th.as_tensor(venv.action_masks())  # the first round: every crane idle
    logits = th.zeros(masks.shape)  # uniform over what each row may do
    tasks = [task_list(env) for env in venv.envs]
    for _ in range(50):
        actions, seen = claim_in_turn(obs, logits, masks, venv.limits, 4)
        assert seen[th.arange(len(actions)), actions].all()
        assert not (seen & ~masks).any()  # claims only remove allowed actions
        for c in range(2):
            chosen = [int(a) - 1 for a in actions[4 * c : 4 * c + 4] if a > 0]
            for i, p in enumerate(chosen):
                for q in chosen[i + 1 :]:
                    assert not tasks[c].conflicts(p)[q]


def test_ppo_s_buffer_keeps_the_masks_each_row_sampled_under():
    cfg = TrainConfig("hall-4c", paper=False, n_cranes=4, decisions="task",
                      algo="maskable_ppo", policy="set", reward="makespan", shaping=0.0,
                      n_envs=2, total_steps=64, checkpoint_every=0)  # fmt: skip
    venv = make_set_vec_env(cfg, 2, 0.99, workers=1)
    params = set_hyperparameters({"n_steps": 8, "batch_size": 32, "n_epochs": 1,
                                  "learning_rate": 0.0})  # fmt: skip
    model = make_set_model(venv, 0, params, None)
    model.policy.claim_rows = venv.n_agents
    model.learn(64)
    buffer = model.rollout_buffer
    obs = th.as_tensor(buffer.observations.reshape(-1, venv.limits.size))
    actions = th.as_tensor(buffer.actions.reshape(-1)).long()
    stored = buffer.action_masks.reshape(len(actions), -1)
    assert stored[np.arange(len(actions)), actions.numpy()].all()
    with th.no_grad():
        _, log_prob, _ = model.policy.evaluate_actions(obs, actions, action_masks=stored)
    # The update's log-probabilities are the rollout's: each action under the mask it saw.
    assert np.allclose(log_prob.numpy(), buffer.log_probs.reshape(-1), atol=1e-5)
    first = stored[: venv.n_agents]  # step 0, copy 0: four idle cranes claimed in turn
    assert (first.sum(1)[1:] < first.sum(1)[0]).all()
