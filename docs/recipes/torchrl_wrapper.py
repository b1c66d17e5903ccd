"""TorchRL 0.14: the multi-agent env under TorchRL's own PettingZooWrapper, no custom wrapper."""

import torch
from torchrl.envs.libs.pettingzoo import PettingZooWrapper

import multicrane

torch.set_num_threads(1)

env = PettingZooWrapper(
    multicrane.parallel_env("e3s2", n_cranes=2),  # numeric infos: TorchRL batches them
    use_mask=True,
    categorical_actions=True,
)
rollout = env.rollout(20)  # random actions; put a TensorDictModule policy here
print(rollout["crane", "observation", "observation"].shape)  # (20, 2, D): steps x cranes
print(rollout["next", "crane", "info", "event_counts"].shape)  # (20, 2, 11)
