"""The lean PPO in the multi-agent motion mode (issue 32, item 1): one shared policy, the N
cranes of B vector copies as B*N rows; its shaping potential, per-crane GAE, masks,
determinism, exact resume, learning, and ``multicrane train`` / ``multicrane evaluate``."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import torch as th  # noqa: E402
from gymnasium import spaces  # noqa: E402

from multicrane.envs.crane_env import MultiCraneEnv  # noqa: E402
from multicrane.training import TrainConfig, train  # noqa: E402
from multicrane.training.config import ConfigError  # noqa: E402
from multicrane.training.lean_ppo import LeanPPO, motion_hyperparameters  # noqa: E402
from multicrane.training.lean_ppo_buffer import compute_gae  # noqa: E402
from multicrane.training.lean_ppo_motion_env import LeanMotionEnv  # noqa: E402
from multicrane.training.shaping import DistancePotential  # noqa: E402
from policies.greedy import GreedyPolicy  # noqa: E402

SMALL = {"n_steps": 8, "batch_size": 32, "n_epochs": 2, "policy_kwargs": {"net_arch": [32, 32]}}


pytestmark = pytest.mark.usefixtures("one_torch_thread")


def quiet(*_args) -> None:
    pass


def make_model(env, seed: int = 0, **changes) -> LeanPPO:
    params = {**motion_hyperparameters(), **SMALL, **changes}
    return LeanPPO("MlpPolicy", env, seed=seed, **params)


def weights(model) -> dict[str, th.Tensor]:
    return {k: v.clone() for k, v in model.policy.state_dict().items()}


def same(a: dict, b: dict) -> bool:
    return a.keys() == b.keys() and all(th.equal(a[k], b[k]) for k in a)


# -- the rows and their shaping ----------------------------------------------------------------


def _greedy_or_random(env: LeanMotionEnv, planners, rng) -> np.ndarray:
    """Per copy: the greedy planner's joint action (9 times in 10), else random legal ones."""
    masks = env.envs.action_masks()
    joint = np.zeros(masks.shape[:2], dtype=np.int64)
    for b, planner in enumerate(planners):
        agents = planner.env.possible_agents
        plan = planner({a: {"action_mask": masks[b, k]} for k, a in enumerate(agents)})
        for k, agent in enumerate(agents):
            legal = np.flatnonzero(masks[b, k])
            joint[b, k] = plan[agent] if rng.random() < 0.9 else rng.choice(legal)
    return joint.reshape(-1)


@pytest.mark.parametrize(("scenario", "options"), [("e2s2", {"max_steps": 45}),
                                                   ("e2s2", {"max_steps": 45, "events": "high"}),
                                                   ("e3s2", {"max_steps": 75})])  # fmt: skip
def test_rows_and_shaped_rewards_equal_the_one_site_envs(scenario, options):
    """Row ``b * N + k`` is crane k of copy b; its reward is the SB3 path's shaped reward:
    the team reward plus ``w (gamma phi(s') - phi(s))`` with ``DistancePotential`` on the
    one-site env, ``phi(s') = 0`` at termination and the last state's at truncation (read
    back from ``final_obs`` after the same-step reset)."""
    seeds, w, gamma = [0, 1, 2], 0.5, 0.9
    env = LeanMotionEnv(scenario, len(seeds), shaping=w, gamma=gamma, n_cranes=2, **options)
    refs = [MultiCraneEnv(scenario, n_cranes=2, obs_format="flat", **options) for _ in seeds]
    obs, masks = env.reset(seed=seeds)
    starts = [ref.reset(seed=s)[0] for ref, s in zip(refs, seeds, strict=True)]
    assert obs.shape == (6, env.observation_space.shape[0])
    assert masks.shape == (6, env.action_space.n)
    assert np.array_equal(obs[3], starts[1]["crane_1"])
    phis = [DistancePotential(ref.sim) for ref in refs]
    before = [phi() for phi in phis]
    rng = np.random.default_rng(0)
    planners = [GreedyPolicy(ref, seed=s) for ref, s in zip(refs, seeds, strict=True)]
    kinds = set()
    for _ in range(120):
        actions = _greedy_or_random(env, planners, rng)
        _, _, rewards, terminated, truncated, final_obs, episodes = env.step(actions)
        ends = 0
        for b, ref in enumerate(refs):
            out = ref.step({a: int(actions[2 * b + k]) for k, a in enumerate(ref.agents)})
            team, term, trunc = out[1]["crane_0"], out[2]["crane_0"], out[3]["crane_0"]
            after = 0.0 if term else phis[b]()
            expected = team + w * (gamma * after - before[b])
            assert rewards[2 * b : 2 * b + 2].tolist() == pytest.approx([expected] * 2), b
            assert terminated[2 * b : 2 * b + 2].tolist() == [term] * 2
            assert truncated[2 * b : 2 * b + 2].tolist() == [trunc] * 2
            if term or trunc:
                kinds.add("terminated" if term else "truncated")
                ends += 1
                assert np.array_equal(final_obs[2 * b + 1], out[0]["crane_1"])
                ref.reset()
                phis[b].reset()
            before[b] = phis[b]()
        assert len(episodes) == ends  # one per copy, not per crane
    assert kinds == {"terminated", "truncated"}


def test_per_crane_gae_on_a_hand_case():
    """One copy of two cranes (rows 0 and 1) and a second copy (rows 2, 3): the cranes of a
    copy share its end but not their rewards (``reward_mode="split"``); each row gets the
    advantages of its own rewards and values."""
    gamma, lam = 0.9, 0.5
    rewards = th.tensor([[1.0, 3.0, 0.0, 0.0], [2.0, -1.0, 1.0, 1.0]])
    values = th.tensor([[0.5, 1.0, 0.1, 0.2], [0.4, 0.3, 0.0, -0.5]])
    dones = th.tensor([[1.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]])  # copy 0 ends at step 0
    last = th.tensor([1.0, 2.0, 3.0, 4.0])
    adv, _ = compute_gae(rewards, values, dones, last, gamma, lam)
    for row in range(4):
        d1 = rewards[1, row] + gamma * last[row] - values[1, row]
        going_on = 1.0 - dones[0, row]
        d0 = rewards[0, row] + gamma * values[1, row] * going_on - values[0, row]
        assert adv[1, row].item() == pytest.approx(d1.item(), abs=1e-6)
        assert adv[0, row].item() == pytest.approx((d0 + gamma * lam * going_on * d1).item(),
                                                   abs=1e-6)  # fmt: skip
    # the adapter's split rewards: each crane its own share, as the env gives them
    env = LeanMotionEnv("e2s2", 2, n_cranes=2, reward_mode="split")
    env.reset(seed=0)
    out = env.step(np.full(4, 6))  # everyone waits
    assert np.array_equal(out[2], env.envs.buffers.rewards.reshape(-1))


def test_masks_are_never_violated():
    """A strict env raises on a masked action: three rollouts of 6 rows (tower cranes with
    reach zones) pass, and the stored actions are allowed by the stored masks (some actions
    were masked)."""
    model = make_model(LeanMotionEnv("towers-3c", 2, n_cranes=3, strict=True))
    model.learn(144)
    buf = model.rollout
    assert bool(buf.masks.gather(2, buf.actions[..., None]).all())
    assert not bool(buf.masks.all())
    assert buf.obs.dtype == th.float32 and buf.obs.shape[1] == 6


def test_same_seed_same_weights():
    runs = []
    for seed in (0, 0, 1):
        model = make_model(LeanMotionEnv("e2s2", 4, shaping=1.0, n_cranes=2), seed=seed)
        model.learn(192)
        runs.append(weights(model))
    assert same(runs[0], runs[1])
    assert not same(runs[0], runs[2])


class _Meeting:
    """A stub of ``LeanMotionEnv``: ``n`` copies of two cranes; each crane sees its own index
    (one-hot) and must send its own action (crane 0: action 0, crane 1: action 1): the team
    earns +1 for each right one and -1 for each wrong one; episodes of 5 steps (truncated)."""

    observation_space = spaces.Box(0, 1, (2,), np.float32)
    action_space = spaces.Discrete(2)

    def __init__(self, n: int):
        self.num_envs = 2 * n
        self.obs = np.tile(np.eye(2, dtype=np.float32), (n, 1))
        self.masks = np.ones((2 * n, 2), dtype=np.int8)
        self.steps, self.returns = np.zeros(n, dtype=np.int64), np.zeros(n)

    def reset(self, seed):
        return self.current()

    def current(self):
        return self.obs, self.masks

    def step(self, actions):
        right = (actions.reshape(-1, 2) == [0, 1]).sum(1)
        team = 2.0 * right - 2
        self.steps += 1
        self.returns += team
        ended = self.steps >= 5
        episodes = [{"r": r, "l": 5, "success": False} for r in self.returns[ended]]
        self.steps[ended], self.returns[ended] = 0, 0.0
        rows = np.repeat(team, 2)
        truncated = np.repeat(ended, 2)
        return (self.obs, self.masks, rows, np.zeros_like(truncated), truncated, self.obs,
                episodes)  # fmt: skip


def test_learns_a_tiny_case():
    """One policy for both cranes learns each crane's own action from its observation."""
    model = make_model(_Meeting(16), n_steps=10, batch_size=80, n_epochs=4,
                       learning_rate=1e-2)  # fmt: skip
    model.learn(320)
    first = np.mean([e["r"] for e in model.ep_info_buffer])
    model.learn(3_200, reset_num_timesteps=False)
    model.ep_info_buffer.clear()
    model.learn(320, reset_num_timesteps=False)
    last = np.mean([e["r"] for e in model.ep_info_buffer])
    assert first < 2 and last > 9  # a random pair scores 0 a step on average, the best 2
    assert model.predict(np.eye(2, dtype=np.float32))[0].tolist() == [0, 1]


def test_a_greedy_team_breaks_its_wait_loops_with_the_lean_models_scores():
    """``SharedModelPolicy`` scores the cranes' options with ``LeanPPO.action_scores`` (the
    wait-loop break): the greedy actions are the best scores, masked ones are ``BLOCKED``."""
    from multicrane.training.model_policy import SharedModelPolicy
    from multicrane.training.set_policy import BLOCKED

    env = MultiCraneEnv("e2s2", n_cranes=2)
    policy = SharedModelPolicy(make_model(LeanMotionEnv("e2s2", 2, n_cranes=2)), env)
    batch, masks = policy._inputs(env.reset(seed=0)[0])
    scores = policy._scores(batch, masks)
    assert (scores[~masks] == BLOCKED).all() and (scores[masks] > BLOCKED).all()
    assert np.array_equal(scores.argmax(1), policy._act(batch, masks))


# -- runs: train, resume, evaluate -------------------------------------------------------------


def cfg(**changes) -> TrainConfig:
    kw = dict(scenario="e2s2", paper=False, n_cranes=2, algo="lean_ppo", total_steps=256,
              n_envs=4, hyperparams=dict(SMALL), eval_episodes=2, checkpoint_every=64,
              max_steps=40)  # fmt: skip
    return TrainConfig(**{**kw, **changes})


def test_train_and_evaluate_commands(tmp_path, capsys):
    from multicrane.cli import main

    out = tmp_path / "run"
    args = ["train", "--scenario", "e2s2", "--cranes", "2", "--algo", "lean_ppo", "--steps",
            "64", "--envs", "4", "--set", "n_steps=8", "--set", "batch_size=32",
            "--eval-episodes", "1", "--no-progress", "--out", str(out)]  # fmt: skip
    assert main(args) == 0
    assert "lean PPO (shared)" in capsys.readouterr().out
    assert main(["evaluate", "--scenario", "e2s2", "--cranes", "2", "--policy", str(out),
                 "--episodes", "1"]) == 0  # fmt: skip
    assert "lean_ppo (run)" in capsys.readouterr().out


@pytest.mark.parametrize(("changes", "message"), [
    ({"auto": True}, "automatic mode"),
    ({"decisions": "task"}, "batched task env"),
])  # fmt: skip
def test_refused_options(tmp_path, changes, message):
    with pytest.raises(ConfigError, match=message):
        train(cfg(**changes), tmp_path / "refused", log=quiet)
