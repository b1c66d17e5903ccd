"""The discount of task-level training with the makespan reward (``algorithms.round_gamma``):
a round is one to many simulated steps, so a discount per round rewards waiting."""

from __future__ import annotations

import numpy as np
import pytest

import policies
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.training import TrainConfig
from multicrane.training.trainer import Run


def _team_rewards(waits: int, seed: int) -> tuple[int, np.ndarray]:
    """The prioritized planner on hall-4c, every crane waiting in the first ``waits`` rounds:
    (makespan, the team's reward per round)."""
    env = MultiCraneEnv("hall-4c", n_cranes=4, decisions="task", reward="makespan")
    observations, _ = env.reset(seed=seed)
    planner = policies.make("prioritized", env, seed)
    rewards = []
    while env.agents:
        joint = planner(observations)
        if len(rewards) < waits:
            joint = dict.fromkeys(joint, 0)
        observations, reward, *_ = env.step(joint)
        rewards.append(float(np.mean(list(reward.values()))))
    return env.sim.state.step_count, np.array(rewards)


def _value(rewards: np.ndarray, gamma: float) -> float:
    return float(np.sum(rewards * gamma ** np.arange(len(rewards))))


@pytest.mark.parametrize("seed", [0, 1])
def test_a_discount_per_round_prefers_a_team_that_waits(seed):
    planner, planned = _team_rewards(0, seed)
    waiting, waited = _team_rewards(60, seed)
    assert waiting >= planner + 50 and len(waited) > len(planned) + 50
    # Discounted per round, the longer episode is worth more: its waits cut the same work
    # into more, one-step rounds, and the later rounds are discounted more.
    assert _value(waited, 0.99) > _value(planned, 0.99)
    # Undiscounted, each episode is worth its completion bonus minus its makespan.
    assert _value(waited, 1.0) < _value(planned, 1.0)
    assert _value(planned, 1.0) - _value(waited, 1.0) == pytest.approx(waiting - planner)


@pytest.mark.parametrize(
    ("settings", "gamma"),
    [
        (dict(decisions="task", reward="makespan", policy="set"), 1.0),
        (dict(decisions="task", reward="makespan", policy="mlp"), 1.0),
        (dict(decisions="task", reward="makespan", policy="set",
              hyperparams={"gamma": 0.97}), 0.97),  # fmt: skip
        (dict(decisions="task", reward="paper", policy="set"), 0.99),
        (dict(decisions="motion", reward="makespan", policy="mlp"), 0.95),
    ],
)
def test_task_level_makespan_training_is_undiscounted(settings, gamma):
    cfg = TrainConfig("e3s2", paper=False, n_cranes=2, algo="maskable_ppo", **settings)
    assert Run(cfg, "unused", log=lambda *a: None).params["gamma"] == gamma
