"""sb3-contrib 2.9 MaskablePPO on the paper's benchmark, straight from gymnasium.make:
``action_masks()`` is reachable without ``.unwrapped``."""

import gymnasium as gym
import torch
from sb3_contrib import MaskablePPO

import multicrane  # noqa: F401  (registers the ids)

torch.set_num_threads(1)

env = gym.make("multicrane/PaperAssembly-E2S2-v0", mask_blocked_moves=True)
env.reset(seed=0)
print(env.action_masks(), env.metadata["render_fps"])
model = MaskablePPO("MlpPolicy", env, n_steps=64, batch_size=64, n_epochs=1, seed=0)
model.learn(total_timesteps=128)
