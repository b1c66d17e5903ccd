"""A small convolutional features extractor over the paper's (x, y, channel) observation grid.

The single-agent benchmark's observation is the (15, 15, 6) plan of docs/paper-spec.md
section 6 flattened to 1,350 numbers; the paper's networks (an MLP over the flat vector)
must learn from scratch that neighbouring numbers are neighbouring cells. ``GridCNN``
reshapes the vector back to (channel, x, y) and applies two 3x3 convolutions (the second
with stride 2) and one linear layer, the inductive bias of "what is next to what". It is a
learner setting of ours, not the paper's: ``hyperparams={"features": "grid_cnn"}``
(command line ``--set features=grid_cnn``), stored in the run's config.json like every
other setting, so resuming and evaluating a run rebuild the same network.

``FEATURES`` names the extractors that ``features`` accepts; ``"flat"`` is the paper's.
"""

from __future__ import annotations

import math

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor

from multicrane.envs.paper_env import N_PAPER_CHANNELS


def grid_shape(observation_space: spaces.Space, channels: int = N_PAPER_CHANNELS):
    """(x, y, channel) of a flat square-grid observation; ValueError naming the shape else."""
    shape = getattr(observation_space, "shape", None)
    n = int(np.prod(shape)) if shape else 0
    side = math.isqrt(n // channels) if n and n % channels == 0 else 0
    flat = isinstance(observation_space, spaces.Box) and len(shape) == 1
    if not flat or side * side * channels != n:
        raise ValueError(
            f"features=grid_cnn needs a flat Box observation of x * x * {channels} numbers "
            f"(the paper's (15, 15, 6) plan), got {observation_space!r}"
        )
    return side, side, channels


class GridCNN(BaseFeaturesExtractor):
    """Flat (x * y * c) observation -> (c, x, y) -> conv 3x3 (``width`` channels) -> conv 3x3
    stride 2 -> linear to ``features_dim``, ReLU after each; inputs multiplied by ``scale``
    first (the paper's PPO divides its observations by 4)."""

    def __init__(
        self,
        observation_space: spaces.Box,
        scale: float = 1.0,
        width: int = 16,
        features_dim: int = 64,
    ):
        super().__init__(observation_space, int(features_dim))
        self.grid = grid_shape(observation_space)
        self.scale = float(scale)
        x, y, c = self.grid
        self.conv = th.nn.Sequential(
            th.nn.Conv2d(c, width, 3, padding=1),
            th.nn.ReLU(),
            th.nn.Conv2d(width, width, 3, stride=2, padding=1),
            th.nn.ReLU(),
            th.nn.Flatten(),
        )
        with th.no_grad():
            n = self.conv(th.zeros(1, c, x, y)).shape[1]
        self.linear = th.nn.Sequential(th.nn.Linear(n, int(features_dim)), th.nn.ReLU())

    def forward(self, observations: th.Tensor) -> th.Tensor:
        x, y, c = self.grid
        grid = observations.reshape(-1, x, y, c).permute(0, 3, 1, 2) * self.scale
        return self.linear(self.conv(grid))


def features_extractor(name: str):
    """The extractor class named by the ``features`` setting (None: the default flatten)."""
    if name not in FEATURES:
        raise ValueError(f"features={name!r}: one of {', '.join(FEATURES)}")
    return FEATURES[name]


FEATURES = {"flat": None, "grid_cnn": GridCNN}
