"""Tianshou 2.0: DQN trained by Tianshou's own off-policy trainer on the paper env (100 steps
here; raise max_epochs and epoch_num_steps for a real run)."""

import gymnasium as gym
import torch
from tianshou.algorithm import DQN
from tianshou.algorithm.modelfree.dqn import DiscreteQLearningPolicy
from tianshou.algorithm.optim import AdamOptimizerFactory
from tianshou.data import Collector, VectorReplayBuffer
from tianshou.env import DummyVectorEnv
from tianshou.trainer import OffPolicyTrainerParams
from tianshou.utils.net.common import Net

import multicrane  # noqa: F401  (registers the Gymnasium ids)

torch.set_num_threads(1)
torch.manual_seed(0)
env_id = "multicrane/PaperAssembly-E2S2-v0"
train_envs = DummyVectorEnv([lambda: gym.make(env_id) for _ in range(2)])
test_envs = DummyVectorEnv([lambda: gym.make(env_id)])
train_envs.seed(0)
test_envs.seed(100)
space = gym.make(env_id)
net = Net(state_shape=space.observation_space.shape, action_shape=space.action_space.n,
          hidden_sizes=[64, 64])  # fmt: skip
policy = DiscreteQLearningPolicy(model=net, action_space=space.action_space, eps_training=0.2)
algorithm = DQN(policy=policy, optim=AdamOptimizerFactory(lr=1e-3), target_update_freq=50)
train_collector = Collector(policy, train_envs, VectorReplayBuffer(2000, 2),
                            exploration_noise=True)  # fmt: skip
test_collector = Collector(policy, test_envs)
result = algorithm.run_training(
    OffPolicyTrainerParams(
        training_collector=train_collector, test_collector=test_collector, max_epochs=1,
        epoch_num_steps=100, collection_step_num_env_steps=20, test_step_num_episodes=1,
        batch_size=32, show_progress=False, verbose=False,
    )  # fmt: skip
)
print(result.best_reward, result.update_step)  # the test return of the best epoch
