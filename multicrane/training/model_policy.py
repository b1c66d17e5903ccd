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


def model_policy(model, env, paper: bool, deterministic: bool = True):
    """The wrapper of ``model`` for ``env``'s mode (``paper``: the single-agent mode)."""
    cls = PaperModelPolicy if paper else SharedModelPolicy
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
