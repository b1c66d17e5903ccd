"""SuperSuit 3.11 + stable-baselines3 2.9: one PPO policy shared by every crane, on the flat
observation (SuperSuit's observation wrappers need a Box) with the per-crane reward split."""

import supersuit as ss
import torch
from stable_baselines3 import PPO

import multicrane

torch.set_num_threads(1)

env = multicrane.parallel_env("e3s2", n_cranes=2, obs_format="flat", reward_mode="split")
env = ss.frame_stack_v1(env, 2)  # any SuperSuit observation wrapper works on the Box
venv = ss.pettingzoo_env_to_vec_env_v1(env)
venv = ss.concat_vec_envs_v1(venv, 1, num_cpus=0, base_class="stable_baselines3")
model = PPO("MlpPolicy", venv, n_steps=64, batch_size=64, n_epochs=1, verbose=0)
model.learn(total_timesteps=128)
