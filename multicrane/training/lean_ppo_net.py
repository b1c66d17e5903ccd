"""The lean PPO's actor-critic network: a sparse first layer, masked logits, seeded sampling.

The paper-mode observation (1,350 whole numbers, docs/paper-spec.md section 6) is about 1-7 %
non-zero, so observations go in as their non-zero entries (``sparse``, a compiled pass) and
the first layer multiplies only those (``SparseLinear``: an ``embedding_bag`` over them, the
same sum as ``x @ W`` without the zeros); it is shared by the
policy and value heads, each a hidden layer of its own. Orthogonal initialisation as in
cleanrl (gain sqrt 2 for hidden layers, 0.01 for the logits, 1 for the value). Masked actions
get the logit ``MASKED_LOGIT``; actions are sampled by the Gumbel-max trick from a
``torch.Generator`` of the learner's own, so a run's draws are its own and can be saved.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
import torch as th
import torch.nn.functional as F
from numba import njit
from torch import nn

MASKED_LOGIT = -1e8  # a masked action's logit: exp() of it is 0, Gumbel noise cannot lift it


def orthogonal(layer: nn.Linear, gain: float) -> nn.Linear:
    nn.init.orthogonal_(layer.weight, gain)
    nn.init.zeros_(layer.bias)
    return layer


class Sparse(NamedTuple):
    """Observations ``[N, D]`` as each row's non-zero entries: ``cols`` ``[N, K]`` (int64)
    and ``values`` ``[N, K]`` (float32), padded with zeros to the longest row's ``K``."""

    cols: th.Tensor
    values: th.Tensor

    def to(self, device) -> Sparse:
        return Sparse(self.cols.to(device), self.values.to(device))

    def rows(self, index: th.Tensor) -> Sparse:
        return Sparse(self.cols[index], self.values[index])


@njit(cache=True)
def _longest_row(obs: np.ndarray) -> int:
    longest = 1  # at least one column, so that an all-zero batch still has a shape
    for i in range(obs.shape[0]):
        count = 0
        for j in range(obs.shape[1]):
            if obs[i, j] != 0:
                count += 1
        longest = max(longest, count)
    return longest


@njit(cache=True)
def _fill(obs: np.ndarray, cols: np.ndarray, values: np.ndarray) -> None:
    for i in range(obs.shape[0]):
        k = 0
        for j in range(obs.shape[1]):
            if obs[i, j] != 0:
                cols[i, k] = j
                values[i, k] = obs[i, j]
                k += 1


def sparse(obs: np.ndarray) -> Sparse:
    """The non-zero entries of observations ``[N, D]`` (or one ``[D]``), as ``Sparse``."""
    obs = np.ascontiguousarray(obs).reshape(-1, obs.shape[-1])
    longest = _longest_row(obs)
    cols = np.zeros((obs.shape[0], longest), dtype=np.int64)
    values = np.zeros((obs.shape[0], longest), dtype=np.float32)
    _fill(obs, cols, values)
    return Sparse(th.from_numpy(cols), th.from_numpy(values))


@njit(cache=True)
def _scatter(cols: np.ndarray, values: np.ndarray, grad: np.ndarray, out: np.ndarray) -> None:
    """``out[cols[i, k]] += values[i, k] * grad[i]``: the weight's gradient, in row order."""
    for i in range(cols.shape[0]):
        for k in range(cols.shape[1]):
            value = values[i, k]
            if value != 0:
                row = cols[i, k]
                for h in range(grad.shape[1]):
                    out[row, h] += value * grad[i, h]


class _SparseMatmul(th.autograd.Function):
    """``embedding_bag``'s weighted sum, with the weight's gradient by ``_scatter`` on the CPU
    (torch's own embedding backward is several times slower there) and ``index_add_`` on a
    GPU."""

    @staticmethod
    def forward(ctx, cols: th.Tensor, values: th.Tensor, weight: th.Tensor) -> th.Tensor:
        ctx.save_for_backward(cols, values)
        ctx.weight_shape = weight.shape
        return F.embedding_bag(cols, weight, mode="sum", per_sample_weights=values)

    @staticmethod
    def backward(ctx, grad: th.Tensor):
        cols, values = ctx.saved_tensors
        out = th.zeros(ctx.weight_shape, dtype=grad.dtype, device=grad.device)
        if grad.device.type == "cpu":
            _scatter(cols.numpy(), values.numpy(), grad.contiguous().numpy(), out.numpy())
        else:
            rows = (values[..., None] * grad[:, None, :]).reshape(-1, grad.shape[1])
            out.index_add_(0, cols.flatten(), rows)
        return None, None, out


class SparseLinear(nn.Module):
    """``x @ weight + bias`` summed over the non-zero entries of each row of ``x`` only
    (``x``: ``Sparse``; ``scale`` multiplies the inputs first)."""

    def __init__(self, n_in: int, n_out: int, scale: float = 1.0, gain: float = math.sqrt(2)):
        super().__init__()
        self.scale = float(scale)
        self.weight = nn.Parameter(th.empty(n_in, n_out))
        self.bias = nn.Parameter(th.zeros(n_out))
        with th.no_grad():  # orthogonal as nn.Linear(n_in, n_out)'s [n_out, n_in] weight
            self.weight.copy_(nn.init.orthogonal_(th.empty(n_out, n_in), gain).T)

    def forward(self, x: Sparse) -> th.Tensor:
        values = x.values * self.scale  # a padding entry's value is 0: it adds nothing
        return _SparseMatmul.apply(x.cols, values, self.weight) + self.bias


def _head(sizes: Sequence[int], n_out: int, gain: float) -> nn.Sequential:
    layers: list[nn.Module] = []
    for a, b in zip(sizes[:-1], sizes[1:], strict=False):
        layers += [orthogonal(nn.Linear(a, b), math.sqrt(2)), nn.Tanh()]
    layers.append(orthogonal(nn.Linear(sizes[-1], n_out), gain))
    return nn.Sequential(*layers)


class ActorCritic(nn.Module):
    """Shared sparse first layer (``net_arch[0]`` units, tanh), then a policy head and a value
    head with the hidden layers ``net_arch[1:]`` each."""

    def __init__(self, n_obs: int, n_actions: int, net_arch: Sequence[int], obs_scale: float):
        super().__init__()
        if not net_arch or any(int(n) < 1 for n in net_arch):
            raise ValueError(f"net_arch={list(net_arch)!r}: one or more positive layer sizes")
        sizes = [int(n) for n in net_arch]
        self.encoder = SparseLinear(n_obs, sizes[0], obs_scale)
        self.actor = _head(sizes, n_actions, 0.01)
        self.critic = _head(sizes, 1, 1.0)

    def features(self, obs: Sparse) -> th.Tensor:
        return th.tanh(self.encoder(obs))

    def value(self, obs: Sparse) -> th.Tensor:
        return self.critic(self.features(obs)).squeeze(-1)

    def logits_and_value(self, obs: Sparse, masks: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        """Masked logits ``[N, A]`` (``masks``: non-zero where allowed) and values ``[N]``."""
        hidden = self.features(obs)
        logits = self.actor(hidden).masked_fill(masks == 0, MASKED_LOGIT)
        return logits, self.critic(hidden).squeeze(-1)


def sample(logits: th.Tensor, generator: th.Generator) -> th.Tensor:
    """One action per row, drawn from ``softmax(logits)`` by the Gumbel-max trick."""
    uniform = th.rand(logits.shape, generator=generator, device=logits.device)
    gumbel = -th.log(-th.log(uniform.clamp_(1e-20, 1.0 - 1e-7)))
    return th.argmax(logits + gumbel, dim=-1)


def log_prob_entropy(logits: th.Tensor, actions: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
    """The log-probabilities of ``actions`` and the entropies of the masked distributions."""
    log_p = F.log_softmax(logits, dim=-1)
    entropy = -(log_p.exp() * log_p).sum(-1)  # masked: exp() is 0, so 0 * (-1e8) adds nothing
    return log_p.gather(-1, actions.unsqueeze(-1)).squeeze(-1), entropy
