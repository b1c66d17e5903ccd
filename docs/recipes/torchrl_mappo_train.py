"""TorchRL 0.14: a tiny MAPPO (shared actor, centralised critic) trained for a few iterations
with TorchRL's own modules, on the multi-agent env under PettingZooWrapper (no custom wrapper)."""

import torch
from tensordict.nn import TensorDictModule
from torchrl.collectors import Collector
from torchrl.envs.libs.pettingzoo import PettingZooWrapper
from torchrl.modules import MaskedCategorical, MultiAgentMLP, ProbabilisticActor
from torchrl.objectives import ClipPPOLoss, ValueEstimators

import multicrane

torch.set_num_threads(1)
torch.manual_seed(0)
env = PettingZooWrapper(multicrane.parallel_env("e3s2", n_cranes=2, max_cycles=40),
                        use_mask=True, categorical_actions=True)  # fmt: skip
env.set_seed(0)
obs_key = ("crane", "observation", "observation")
n_obs = env.observation_spec[obs_key].shape[-1]
n_actions = env.full_action_spec[env.action_key].space.n
mlp = dict(n_agents=2, share_params=True, depth=1, num_cells=32)  # fmt: skip
actor_net = MultiAgentMLP(n_obs, n_actions, centralised=False, **mlp)
policy = ProbabilisticActor(
    TensorDictModule(actor_net, in_keys=[obs_key], out_keys=[("crane", "logits")]),
    in_keys={"logits": ("crane", "logits"), "mask": ("crane", "action_mask")},
    out_keys=[env.action_key], distribution_class=MaskedCategorical, return_log_prob=True,
)  # fmt: skip
critic = TensorDictModule(MultiAgentMLP(n_obs, 1, centralised=True, **mlp),
                          in_keys=[obs_key], out_keys=[("crane", "state_value")])  # fmt: skip
loss = ClipPPOLoss(policy, critic, normalize_advantage=False)
loss.set_keys(reward=env.reward_key, action=env.action_key, value=("crane", "state_value"),
              done=("crane", "done"), terminated=("crane", "terminated"),
              sample_log_prob=("crane", "action_log_prob"))  # fmt: skip
loss.make_value_estimator(ValueEstimators.GAE, gamma=0.99, lmbda=0.95)
optim = torch.optim.Adam(loss.parameters(), lr=3e-4)
collector = Collector(env, policy, frames_per_batch=80, total_frames=240)
for i, batch in enumerate(collector):
    with torch.no_grad():
        loss.value_estimator(batch, params=loss.critic_network_params,
                             target_params=loss.target_critic_network_params)  # fmt: skip
    out = loss(batch)
    total = out["loss_objective"] + out["loss_critic"] + out["loss_entropy"]
    optim.zero_grad()
    total.backward()
    optim.step()
    print(i, total.item(), batch["next", env.reward_key].mean().item())
collector.shutdown()
