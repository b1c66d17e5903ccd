"""The set-based shared policy: components and cranes as sets, a pointer head over tasks.

``SetExtractor`` reads a padded set observation (``multicrane.training.set_obs``): each
component row and each crane row becomes a token (a shared MLP); with ``heads > 0`` one
masked self-attention block mixes them, with ``heads=0`` (the default of
``multicrane.training.set_training``) they stay unmixed (DeepSets: a shared MLP per row, then
pooling; about 1.5x cheaper to train). A masked mean gives the site's summary ``g``; the
observing crane's token is ``s`` (its ``self`` flag picks it). Each task's logit comes from
its own row (its component index only picks that component's token), the token of its
component, ``s`` and ``g`` (a shared MLP: a pointer head), so one network takes any number of
components, cranes and tasks; the wait logit comes from ``s`` and ``g``. The critic reads
``[g, s]`` (an agent-specific global state, as in MAPPO).

Which crane can reach a component is a column per crane in the observation; the network
turns those columns into two crane-order-free features, "the observing crane can reach it"
and "the share of cranes that can", so permuting the cranes (rows and their reach columns
together) does not change a crane's output. Permuting components (with the tasks' component
indices) leaves every task's logit unchanged, permuting tasks permutes the logits, and
padding rows change nothing (masked out of the attention, the means and the logits); the
tests check all three.

With site events (``SetLimits.events``) the component token also reads the ``delivered``
column and the crane token the ``available`` column (``multicrane.training.set_obs``).

With the planner's hint (``SetLimits.hint``) the task row's ``proposed`` column goes into the
task MLP, and two learned scalars add it directly: ``hint_gain`` times it to the task's
logit, ``hint_wait`` to the wait logit when the planner proposes no task for the crane (both
start at 0: the hint weighs what training makes it weigh).

Only allowed (row, task) pairs go through the task MLP: a task that is not allowed gets the
logit ``-1e8`` whatever the mask, so no illegal task is ever chosen, and a busy crane's row
(no task allowed) costs the task head nothing. ``SetPolicy`` is MaskablePPO's policy with this
extractor and the pointer logits as its action logits (no extra linear layer).
"""

from __future__ import annotations

import numpy as np
import torch as th
from gymnasium import spaces
from sb3_contrib.common.maskable.policies import MaskableActorCriticPolicy
from stable_baselines3.common.torch_layers import BaseFeaturesExtractor
from torch import nn

from multicrane.training.claims import claim_in_turn
from multicrane.training.set_obs import HEADER, N_COMP, N_CRANE, N_TASK, SetLimits

WAIT_BIAS = -2.0  # the wait logit's initial bias (see SetExtractor.__init__)
BLOCKED = -1e8  # the logit of a task that is not allowed (MaskablePPO's own masked value)
_SELF, _ALLOWED, _COMPONENT = 0, N_TASK - 1, 0  # feature columns: cranes' self, tasks'


def _mlp(n_in: int, d: int, n_out: int | None = None) -> nn.Sequential:
    return nn.Sequential(nn.Linear(n_in, d), nn.ReLU(), nn.Linear(d, n_out or d))


class SetExtractor(BaseFeaturesExtractor):
    """Features ``[logits (1 + P), g (d), s (d)]`` of a padded set observation; see the module
    doc. ``limits``: the padded table sizes (a ``SetLimits`` or its dict); ``dim``: token
    width; ``heads``: attention heads (0: no attention, DeepSets pooling of the tokens)."""

    def __init__(self, observation_space: spaces.Box, limits, dim: int = 64, heads: int = 4):
        limits = SetLimits(**limits) if isinstance(limits, dict) else limits
        if observation_space.shape != (limits.size,):
            raise ValueError(
                f"observation shape {observation_space.shape} is not that of the set limits "
                f"{limits.to_dict()} ({limits.size},)"
            )
        super().__init__(observation_space, limits.n_actions + 2 * dim)
        self.limits, self.dim = limits, dim
        ev = int(limits.events)  # the delivered / available columns (site events)
        self.comp_in = _mlp(N_COMP + 2 + ev, dim)
        self.crane_in = _mlp(N_CRANE + ev, dim)
        self.kind = nn.Parameter(th.zeros(2, dim))  # component / crane token offsets
        self.heads = heads
        if heads:
            self.attn = nn.MultiheadAttention(dim, heads, batch_first=True)
            self.norm1, self.norm2 = nn.LayerNorm(dim), nn.LayerNorm(dim)
            self.ff = _mlp(dim, 2 * dim, dim)
        self.task_in = nn.Linear(limits.task_width - 1, dim)  # all but the component index
        if limits.hint:  # the planner's proposal straight into the logits (set_obs doc)
            self.hint_gain = nn.Parameter(th.zeros(()))  # on the proposed task's logit
            self.hint_wait = nn.Parameter(th.zeros(()))  # on waiting, when none is proposed
        self.task_ctx = nn.Linear(2 * dim, dim)
        self.task_out = _mlp(dim, dim, 1)
        self.wait_out = _mlp(2 * dim, dim, 1)
        for head in (self.task_out[-1], self.wait_out[-1]):
            nn.init.orthogonal_(head.weight, gain=0.01)
            nn.init.zeros_(head.bias)
        # Waiting starts unlikely: with all logits equal an untrained greedy policy would
        # wait forever (every round one simulated step, to the step limit).
        nn.init.constant_(self.wait_out[-1].bias, WAIT_BIAS)

    summary_only = False  # True for a critic's own copy (SetPolicy, unshared): g and s only

    def split(self, obs: th.Tensor) -> dict[str, th.Tensor]:
        """The padded tables of a batch: counts (B, 3), components, cranes and tasks."""
        out = {"counts": obs[:, :HEADER]}
        for name, (a, b, shape) in self.limits.slices().items():
            out[name] = obs[:, a:b].reshape(-1, *shape)
        return out

    def forward(self, obs: th.Tensor) -> th.Tensor:
        t = self.split(obs)
        B = obs.shape[0]
        Cm, Nm, Pm = self.limits.components, self.limits.cranes, self.limits.tasks
        counts = t["counts"].round().long()
        c_ok = th.arange(Cm, device=obs.device)[None, :] < counts[:, :1]  # (B, C)
        k_ok = th.arange(Nm, device=obs.device)[None, :] < counts[:, 1:2]  # (B, N)
        comp, cranes, tasks = t["components"], t["cranes"], t["tasks"]
        me = cranes[:, :, _SELF] * k_ok  # (B, N) one-hot of the observing crane
        reach = comp[:, :, N_COMP : N_COMP + Nm]  # (B, C, N)
        reach_self = (reach * me[:, None, :]).sum(-1, keepdim=True)
        n_cranes = k_ok.sum(-1).clamp(min=1)[:, None, None]
        reach_share = (reach * k_ok[:, None, :]).sum(-1, keepdim=True) / n_cranes
        extra = comp[:, :, N_COMP + Nm :]  # (B, C, 1) delivered, with events; else empty
        hc = self.comp_in(th.cat([comp[:, :, :N_COMP], reach_self, reach_share, extra], -1))
        hk = self.crane_in(cranes)
        x = th.cat([hc + self.kind[0], hk + self.kind[1]], 1)  # (B, C + N, d)
        ok = th.cat([c_ok, k_ok], 1)
        if self.heads:
            a, _ = self.attn(x, x, x, key_padding_mask=~ok, need_weights=False)
            x = self.norm1(x + a)
            x = self.norm2(x + self.ff(x))
        w = ok.unsqueeze(-1).float()
        g = (x * w).sum(1) / w.sum(1).clamp(min=1)
        s = (x[:, Cm:] * me.unsqueeze(-1)).sum(1)
        gs = th.cat([g, s], -1)
        if self.summary_only:  # a critic's own extractor: no logits to compute
            return th.cat([gs.new_zeros(B, 1 + Pm), g, s], -1)

        logits = th.full((B, Pm), BLOCKED, dtype=obs.dtype, device=obs.device)
        allowed = tasks[:, :, _ALLOWED] > 0.5
        allowed &= th.arange(Pm, device=obs.device)[None, :] < counts[:, 2:3]
        rows, cols = allowed.nonzero(as_tuple=True)
        if rows.numel():
            row_t = tasks[rows, cols]  # (K, task_width)
            n_c = (counts[rows, 0] - 1).clamp(min=1).float()
            comp_idx = (row_t[:, _COMPONENT] * n_c).round().long().clamp(0, Cm - 1)
            h = self.task_in(row_t[:, 1:]) + x[rows, comp_idx] + self.task_ctx(gs)[rows]
            out = self.task_out(th.relu(h)).squeeze(-1)
            if self.limits.hint:
                out = out + self.hint_gain * row_t[:, N_TASK]
            logits = logits.index_put((rows, cols), out)
        wait = self.wait_out(gs)
        if self.limits.hint:
            none = 1.0 - tasks[:, :, N_TASK].amax(1, keepdim=True)  # (B, 1)
            wait = wait + self.hint_wait * none
        return th.cat([wait, logits, g, s], -1)


class _Heads(nn.Module):
    """SB3's ``mlp_extractor`` slot: the actor's latent is the logits, the critic's an MLP of
    ``[g, s]``."""

    def __init__(self, n_logits: int, dim: int):
        super().__init__()
        self.n_logits = n_logits
        self.latent_dim_pi = n_logits
        self.latent_dim_vf = dim
        self.critic = nn.Sequential(nn.Linear(2 * dim, dim), nn.ReLU())

    def forward(self, features: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
        return self.forward_actor(features), self.forward_critic(features)

    def forward_actor(self, features: th.Tensor) -> th.Tensor:
        return features[:, : self.n_logits]

    def forward_critic(self, features: th.Tensor) -> th.Tensor:
        return self.critic(features[:, self.n_logits :])


def latents(policy, obs: th.Tensor) -> tuple[th.Tensor, th.Tensor]:
    """The actor's and the critic's latents of an SB3 actor-critic ``policy``, with one
    feature extractor shared or one each."""
    features = policy.extract_features(obs)
    if policy.share_features_extractor:
        return policy.mlp_extractor(features)
    return (policy.mlp_extractor.forward_actor(features[0]),
            policy.mlp_extractor.forward_critic(features[1]))  # fmt: skip


class SetPolicy(MaskableActorCriticPolicy):
    """MaskablePPO's actor-critic with ``SetExtractor``; the logits are the pointer head's.

    ``policy_kwargs``: ``{"features_extractor_kwargs": {"limits": {...}, "dim": 64}}``; with
    ``"share_features_extractor": False`` the critic has its own extractor (its gradients
    never move the actor's tokens), which computes only the summary ``[g, s]``."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("features_extractor_class", SetExtractor)
        kwargs.setdefault("ortho_init", False)  # the extractor initialises its own heads
        kwargs.setdefault("share_features_extractor", True)
        super().__init__(*args, **kwargs)

    claim_rows: int | None = None  # crane rows per copy: PPO's rollouts claim in turn

    def forward(self, obs: th.Tensor, deterministic: bool = False,
                action_masks: np.ndarray | None = None):  # fmt: skip
        """MaskablePPO's rollout step. With ``claim_rows`` (set by the training run) the crane
        rows of each copy sample one after the other as deployed (``claims.claim_in_turn``),
        and ``action_masks`` is overwritten with the masks each row saw: the rollout buffer
        stores that same array, so PPO's update evaluates each action under its own mask."""
        if self.claim_rows is None or action_masks is None:
            return super().forward(obs, deterministic, action_masks)
        latent_pi, latent_vf = latents(self, obs)
        masks = th.as_tensor(np.asarray(action_masks, dtype=bool).reshape(len(obs), -1))
        limits = self.features_extractor.limits
        actions, seen = claim_in_turn(obs, latent_pi, masks, limits, self.claim_rows,
                                      deterministic)  # fmt: skip
        action_masks[...] = seen.numpy().reshape(np.shape(action_masks))
        distribution = self._get_action_dist_from_latent(latent_pi)
        distribution.apply_masking(seen)
        return actions, self.value_net(latent_vf), distribution.log_prob(actions)

    def _build_mlp_extractor(self) -> None:
        extractor = self.features_extractor
        self.mlp_extractor = _Heads(extractor.limits.n_actions, extractor.dim)

    def _build(self, lr_schedule) -> None:
        super()._build(lr_schedule)
        if not self.share_features_extractor:  # the critic reads only its extractor's [g, s]
            self.vf_features_extractor.summary_only = True
        self.action_net = nn.Identity()  # the logits are the actor's latent
        self.optimizer = self.optimizer_class(
            self.parameters(), lr=lr_schedule(1), **self.optimizer_kwargs
        )


class SetActor:
    """The acting half of a trained ``SetPolicy`` for observations padded to ``limits`` (any
    limits: the network does not depend on the table sizes, so a policy trained on small
    sites can play bigger ones with the same weights)."""

    def __init__(self, policy: SetPolicy, limits: SetLimits | None = None):
        old = policy.features_extractor
        if limits is None or limits == old.limits:
            self.extractor = old
        else:
            self.extractor = SetExtractor(spaces.Box(0, 1e4, (limits.size,)), limits, old.dim,
                                          old.heads)  # fmt: skip
            self.extractor.load_state_dict(old.state_dict())
        self.limits = self.extractor.limits

    def logits(self, batch, masks) -> th.Tensor:
        """The masked logits, one row per observation (``BLOCKED`` where not allowed)."""
        if self.extractor.training:  # eval() walks every submodule: once, not every call
            self.extractor.eval()
        with th.inference_mode():
            logits = self.extractor(th.as_tensor(batch))[:, : self.limits.n_actions]
            return th.where(th.as_tensor(masks), logits, th.full_like(logits, BLOCKED))

    def __call__(self, batch, masks, deterministic: bool = True):
        """One action per row: the best (or a sampled) allowed action."""
        logits = self.logits(batch, masks)
        if deterministic:
            return logits.argmax(-1).numpy()
        with th.no_grad():
            return th.distributions.Categorical(logits=logits).sample().numpy()
