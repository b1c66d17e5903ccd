"""Trained stable-baselines3 models as policies, and loading them from a run directory.

    from multicrane.training.model_policy import load_run
    model, config = load_run("runs/e2s2-maskable_ppo-s0")     # a directory ``train`` wrote
    policy = PaperModelPolicy(model, env)   # single-agent mode: policy(obs) -> action
    policy = SharedModelPolicy(model, env)  # multi-agent mode: policy(observations) -> actions

Both act greedily (``deterministic=True``); a masked model gets the environment's masks.
``policies.make`` plugs these into the policy registry (a run directory or ``model.zip`` as a
policy name).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from multicrane.training.algorithms import algorithm
from multicrane.training.config import CHECKPOINT, TrainConfig


def _is_masked(model) -> bool:
    from sb3_contrib import MaskablePPO

    return isinstance(model, MaskablePPO)


class PaperModelPolicy:
    """A model trained on ``PaperAssemblyEnv``: ``policy(observation) -> action``."""

    def __init__(self, model, env, deterministic: bool = True):
        self.model = model
        self.env = env
        self.masked = _is_masked(model)
        self.deterministic = deterministic

    def __call__(self, observation) -> int:
        kwargs = {"action_masks": self.env.unwrapped.action_masks()} if self.masked else {}
        action, _ = self.model.predict(observation, deterministic=self.deterministic, **kwargs)
        return int(action)


class SharedModelPolicy:
    """One model acting for every crane of a ``MultiCraneEnv`` (parameter sharing):
    ``policy(observations) -> {agent: action}``, all cranes in one batch."""

    def __init__(self, model, env, deterministic: bool = True):
        self.model = model
        self.env = env
        self.masked = _is_masked(model)
        self.deterministic = deterministic

    def __call__(self, observations: dict) -> dict:
        agents = list(observations)
        batch = np.stack([observations[a]["observation"] for a in agents])
        kwargs = {}
        if self.masked:
            kwargs["action_masks"] = np.stack(
                [observations[a]["action_mask"] for a in agents]
            ).astype(bool)
        actions, _ = self.model.predict(batch, deterministic=self.deterministic, **kwargs)
        return {a: int(x) for a, x in zip(agents, actions, strict=True)}


class SetModelPolicy(SharedModelPolicy):
    """A set policy (``multicrane.training.set_policy``) acting for every crane of a task-mode
    ``MultiCraneEnv`` of any site that fits its limits: observations and masks are padded
    (``multicrane.training.set_obs``) and the cranes go in one batch. A site bigger than the
    model's limits is played by a copy of the network resized to it (same weights)."""

    def __init__(self, model, env, deterministic: bool = True):
        from multicrane.training.set_obs import Padder, union
        from multicrane.training.set_policy import SetActor

        super().__init__(model, env, deterministic)
        limits = model.policy.features_extractor.limits
        if not limits.fits(env.observation_layout):
            if env.observation_layout.events is not None and not limits.events:
                limits.check(env.observation_layout, env.scenario.name)  # names the option
            limits = union([env.observation_layout, _Layout(**limits.to_dict())])
        self.actor = SetActor(model.policy, limits)
        self.padder = Padder(env.observation_layout, self.actor.limits)

    def __call__(self, observations: dict) -> dict:
        agents = list(observations)
        pad = self.padder
        batch = np.stack([pad.pad(observations[a]["observation"]) for a in agents])
        masks = np.stack([pad.pad_mask(observations[a]["action_mask"]) for a in agents])
        actions = self.actor(batch, masks, self.deterministic)
        return {a: int(x) for a, x in zip(agents, actions, strict=True)}


class _Layout:
    """Table sizes in ``TaskLayout``'s attribute names (for ``set_obs.union``)."""

    def __init__(self, components: int, cranes: int, tasks: int, events: bool = False):
        self.n_components, self.n_cranes, self.n_tasks = components, cranes, tasks
        self.events = (1, 1) if events else None  # only whether it is there matters


def _is_set(model) -> bool:
    from multicrane.training.set_policy import SetPolicy

    return isinstance(getattr(model, "policy", None), SetPolicy)


def model_policy(model, env, paper: bool, deterministic: bool = True):
    """The wrapper of ``model`` for ``env``'s mode (``paper``: the single-agent mode)."""
    cls = PaperModelPolicy if paper else SetModelPolicy if _is_set(model) else SharedModelPolicy
    return cls(model, env, deterministic=deterministic)


def load_run(path: str | Path, which: str = "final"):
    """(model, ``TrainConfig``) of a training run directory; ``which`` is ``"final"`` (its
    ``model.zip``), or ``"checkpoint"`` for the latest checkpoint of an unfinished run."""
    run_dir = Path(path)
    cfg = TrainConfig.load(run_dir / "config.json")
    algo = algorithm(cfg.algo, cfg.paper)
    model_path = run_dir / ("model.zip" if which == "final" else f"{CHECKPOINT}/model.zip")
    if not model_path.exists():
        raise FileNotFoundError(f"{model_path}: no {which} model in this run directory")
    return algo.cls.load(model_path, device="cpu"), cfg
