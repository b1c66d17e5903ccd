"""RLlib 2.60 (new API stack): one shared masked PPO policy for all cranes, on a local Ray.

On a cluster, join it instead: ray.init(address="auto") (or run
`multicrane train --backend rllib --scenario e3s2 --cranes 2 --address auto` on a node).
"""

import ray
import torch

from multicrane.integrations import rllib as mc_rllib

torch.set_num_threads(1)
ray.init(address="local", num_cpus=2, include_dashboard=False,
         runtime_env={"env_vars": {"OMP_NUM_THREADS": "1"}})  # fmt: skip
config = mc_rllib.ppo_config(  # the env, the masked module, one policy "shared"
    "e2s2", n_cranes=2, num_env_runners=1,
    training={"train_batch_size_per_learner": 200, "minibatch_size": 100, "num_epochs": 1},
)  # fmt: skip
algo = config.build_algo()
result = algo.train()
print(result["env_runners"]["episode_return_mean"])  # team return (reward_mode="split")
module = algo.get_module(mc_rllib.POLICY_ID)  # or mc_rllib.load_module(checkpoint dir)
algo.stop()
ray.shutdown()
