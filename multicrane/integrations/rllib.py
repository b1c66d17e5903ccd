"""RLlib's new API stack: the environments registered, a masked shared-policy module, PPO config.

    from multicrane.integrations import rllib as mc_rllib
    config = mc_rllib.ppo_config("e3s2", n_cranes=2, num_env_runners=2)
    algo = config.build_algo()          # after ray.init(...) or on a cluster
    algo.train()

Needs the ``rllib`` extra (``pip install "multicrane[rllib]"``: ray[rllib] 2.60, torch).

- ``CraneMultiAgentEnv``: ``multicrane.parallel_env`` as an RLlib ``MultiAgentEnv``. Each
  crane's observation is ``{"observations": vector, "action_mask": float32 0/1 vector}``,
  the keys RLlib's action-masking module reads (the environment's own keys are
  ``observation`` and an int8 ``action_mask``). Options go in ``env_config``: ``scenario``,
  ``n_cranes`` and any keyword of ``MultiCraneEnv`` (``reward_mode`` defaults to ``"split"``
  here, so RLlib's episode return, a sum over agents, is the team return).
- ``register_envs()``: registers ``"multicrane"`` (options from ``env_config``), one
  ``"multicrane/<scenario>-v0"`` per shipped scenario, and the paper's Gymnasium ids with
  Ray Tune's registry, which Ray ships to every worker: remote env runners find them
  without importing anything first (the module must still be installed on every node).
- ``shared_module_spec()``: one RL module for all cranes, RLlib's own
  ``ActionMaskingTorchRLModule`` (its action-masking example): PPO's default MLP over
  ``observations``, with the logits of illegal actions pushed to the float minimum.
- ``ppo_config()``: a ``PPOConfig`` training that one shared policy. It hands RLlib the
  environment class itself (pickled to the workers), not a registered name: Ray Tune's
  registry keeps the first Ray session's job id, so a name registered in a second session
  of the same process is not found by that session's workers.
- ``ModulePolicy``: a trained module as a multicrane policy (``policy(observations) ->
  {agent: action}``, greedy among legal actions) for ``multicrane.episodes.rollout``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

import multicrane
from multicrane.envs.paper_env import PAPER_CONFIGS, paper_env_id
from multicrane.scenario.catalog import scenario_names

try:
    import gymnasium as gym
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
    from ray.rllib.core.rl_module.rl_module import RLModuleSpec
    from ray.rllib.env.multi_agent_env import MultiAgentEnv
    from ray.rllib.examples.rl_modules.classes.action_masking_rlm import (
        ActionMaskingTorchRLModule,
    )
    from ray.tune.registry import register_env
except ImportError as exc:  # pragma: no cover - depends on the installed extras
    raise ImportError(
        "multicrane.integrations.rllib needs RLlib: pip install 'multicrane[rllib]' "
        f"(missing: {exc.name})"
    ) from exc

POLICY_ID = "shared"
ENV_NAME = "multicrane"
DEFAULT_HIDDEN = (128, 128)


class CraneMultiAgentEnv(MultiAgentEnv):
    """``multicrane.parallel_env`` as an RLlib ``MultiAgentEnv`` (see the module doc)."""

    def __init__(self, config: dict[str, Any] | None = None):
        super().__init__()
        options = dict(config or {})
        scenario = options.pop("scenario", "e2s2")
        n_cranes = options.pop("n_cranes", None)
        options.setdefault("reward_mode", "split")
        if options.get("obs_format", "dict") != "dict":
            raise ValueError(
                f"env_config obs_format={options['obs_format']!r}: the RLlib adapter needs "
                "the dict observation (it carries the action mask)"
            )
        self.env = multicrane.parallel_env(scenario, n_cranes=n_cranes, **options)
        self.possible_agents = list(self.env.possible_agents)
        self.agents = list(self.possible_agents)
        n_actions = self.env.action_space(self.possible_agents[0]).n
        mask = gym.spaces.Box(0.0, 1.0, (n_actions,), np.float32)
        self.observation_spaces = {
            a: gym.spaces.Dict(
                {"observations": self.env.observation_space(a)["observation"], "action_mask": mask}
            )
            for a in self.possible_agents
        }
        self.action_spaces = {a: self.env.action_space(a) for a in self.possible_agents}

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        observations, infos = self.env.reset(seed=seed, options=options)
        self.agents = list(self.env.agents)
        return _rename(observations), infos

    def step(self, action_dict: dict[str, Any]):
        observations, rewards, terms, truncs, infos = self.env.step(action_dict)
        self.agents = list(self.env.agents)
        terms["__all__"] = all(terms.values())
        truncs["__all__"] = all(truncs.values()) and not terms["__all__"]
        return _rename(observations), rewards, terms, truncs, infos

    def render(self):
        return self.env.render()

    def close(self) -> None:
        self.env.close()


def _rename(observations: dict[str, dict]) -> dict[str, dict]:
    """The environment's observation keys as RLlib's masking module reads them."""
    return {
        a: {
            "observations": o["observation"],
            "action_mask": o["action_mask"].astype(np.float32),
        }
        for a, o in observations.items()
    }


def _scenario_env(name: str):
    def make(config: dict | None = None) -> CraneMultiAgentEnv:
        return CraneMultiAgentEnv({"scenario": name, **dict(config or {})})

    return make


def _paper_env(config_name: str):
    def make(config: dict | None = None):
        return gym.make(paper_env_id(config_name), **dict(config or {}))

    return make


def register_envs() -> list[str]:
    """Register the environments with Ray Tune's registry (see the module doc); their names."""
    names = [ENV_NAME]
    register_env(ENV_NAME, CraneMultiAgentEnv)
    for name in scenario_names():
        env_id = f"multicrane/{name}-v0"
        register_env(env_id, _scenario_env(name))
        names.append(env_id)
    for config in PAPER_CONFIGS:
        register_env(paper_env_id(config), _paper_env(config))
        names.append(paper_env_id(config))
    return names


def shared_module_spec(hidden: tuple[int, ...] = DEFAULT_HIDDEN) -> MultiRLModuleSpec:
    """One masked PPO module, ``"shared"``, for every crane."""
    model = {"fcnet_hiddens": list(hidden), "head_fcnet_hiddens": list(hidden)}
    spec = RLModuleSpec(module_class=ActionMaskingTorchRLModule, model_config=model)
    return MultiRLModuleSpec(rl_module_specs={POLICY_ID: spec})


def _shared(agent_id, episode, **kwargs) -> str:
    return POLICY_ID


def ppo_config(
    scenario: str = "e2s2",
    n_cranes: int | None = None,
    *,
    env_options: dict[str, Any] | None = None,
    num_env_runners: int = 2,
    seed: int = 0,
    hidden: tuple[int, ...] = DEFAULT_HIDDEN,
    training: dict[str, Any] | None = None,
) -> PPOConfig:
    """PPO training one shared masked policy for every crane of ``scenario``.

    ``training`` overrides ``PPOConfig.training`` keywords (``lr``, ``num_epochs``,
    ``train_batch_size_per_learner``, ``minibatch_size``, ...). Every env runner builds its
    own environment, seeded by RLlib from ``seed``."""
    env_config = {"scenario": scenario, "n_cranes": n_cranes, **dict(env_options or {})}
    CraneMultiAgentEnv(env_config).close()  # a bad scenario or option fails here, not remotely
    config = (
        PPOConfig()
        .environment(CraneMultiAgentEnv, env_config=env_config)
        .env_runners(num_env_runners=num_env_runners, num_cpus_per_env_runner=1)
        .multi_agent(policies={POLICY_ID}, policy_mapping_fn=_shared)
        .rl_module(rl_module_spec=shared_module_spec(hidden))
        .debugging(seed=seed)
    )
    if training:
        try:
            config = config.training(**training)
        except TypeError as exc:
            raise ValueError(f"RLlib PPO training option: {exc}") from None
    return config


class ModulePolicy:
    """A trained shared module as a multicrane policy: the legal action of highest logit."""

    def __init__(self, module):
        import torch

        self.torch = torch
        self.module = module

    def __call__(self, observations: dict[str, dict]) -> dict[str, int]:
        agents = list(observations)
        batch = _rename(observations)
        obs = {
            key: self.torch.as_tensor(np.stack([batch[a][key] for a in agents]))
            for key in ("observations", "action_mask")
        }
        with self.torch.no_grad():
            out = self.module.forward_inference({"obs": obs})
        logits = out["action_dist_inputs"].numpy()
        return {a: int(np.argmax(logits[i])) for i, a in enumerate(agents)}


def load_module(checkpoint: str):
    """The shared RL module of an algorithm checkpoint (``Algorithm.save_to_path``)."""
    from pathlib import Path

    from ray.rllib.core.rl_module.rl_module import RLModule

    path = Path(checkpoint) / "learner_group" / "learner" / "rl_module" / POLICY_ID
    if not path.is_dir():
        raise FileNotFoundError(f"{checkpoint}: no RLlib checkpoint of policy {POLICY_ID!r}")
    return RLModule.from_checkpoint(path)
