"""Tianshou 2.0: its Collector runs the paper env, and the multi-agent env through its
PettingZoo wrapper (random masked policies here; put your trained policies in their place)."""

import gymnasium as gym
import numpy as np
import torch
from tianshou.algorithm.algorithm_base import Policy
from tianshou.algorithm.multiagent.marl import MultiAgentPolicy
from tianshou.algorithm.random import MARLRandomDiscreteMaskedOffPolicyAlgorithm
from tianshou.data import Batch, Collector, VectorReplayBuffer
from tianshou.env import DummyVectorEnv, PettingZooEnv

import multicrane

torch.set_num_threads(1)


class RandomMoves(Policy):
    """A uniformly random move (the paper env's six actions), from its own seed."""

    rng = np.random.default_rng(0)

    def forward(self, batch, state=None, **kwargs):
        return Batch(act=self.rng.integers(self.action_space.n, size=len(batch.obs)))


# Single agent: the paper's benchmark.
paper = DummyVectorEnv([lambda: gym.make("multicrane/PaperAssembly-E2S2-v0") for _ in range(2)])
collector = Collector(RandomMoves(action_space=paper.action_space[0]), paper,
                      VectorReplayBuffer(400, 2))  # fmt: skip
collector.reset()
paper_stats = collector.collect(n_step=200)

# Multi-agent: the AEC form through Tianshou's PettingZooEnv (one policy per crane).
aec = PettingZooEnv(multicrane.env("e3s2", n_cranes=2))
policies = {a: MARLRandomDiscreteMaskedOffPolicyAlgorithm(aec.action_space).policy
            for a in aec.agents}  # fmt: skip
cranes = DummyVectorEnv([lambda: PettingZooEnv(multicrane.env("e3s2", n_cranes=2))])
collector = Collector(MultiAgentPolicy(policies), cranes, VectorReplayBuffer(400, 1))
collector.reset()
marl_stats = collector.collect(n_step=100)
print(paper_stats.n_collected_steps, marl_stats.n_collected_steps)
