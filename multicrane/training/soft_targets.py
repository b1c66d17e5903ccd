"""Soft imitation targets: a search teacher's values of its candidates as a distribution.

Behaviour cloning fits the one action a teacher played. The look-ahead planner
(``policies.lookahead.TaskLookahead``) knows more: for the first idle crane of a round it
finished each candidate action on a copy of the site, and each copy's makespan says how good
the candidate is. ``record`` keeps those makespans with the demonstration rows (``values``:
rows x actions, NaN where the teacher evaluated nothing); ``targets`` turns a row's values into
``softmax(-(makespan - best) / tau)`` over the evaluated actions (the row's label among them;
a row without values, or ``tau = 0``, keeps the one-hot label), and ``actor_loss`` is the
cross-entropy of the policy's masked distribution against them (``imitation.clone`` with
``soft=tau``; ``multicrane train --imitate-soft TAU``). The distillation of a search's value
estimates rather than its choice (as AlphaZero fits the search's visit counts).

Waiting is left out of the targets unless it is the label (``wait=False``, the default): its
copy waits one round and then lets the planner choose, so its makespan is often the best's
(on hall-4c in 47 % of the valued rows, within one step in another 33 %), but a policy that
learns to wait waits again in the next round; fitted with it, the policy waited its way to
about 455 steps (docs/marl-results.md, "Soft targets").
"""

from __future__ import annotations

import numpy as np
import torch as th


def record(teacher, agents: list[str], masks: np.ndarray, block: slice, out: np.ndarray) -> None:
    """Write ``teacher``'s last round's candidate makespans (``teacher.values``: ``(agent,
    {action: makespan})`` or None) into ``out``'s rows of ``block`` (a copy's crane rows in
    ``agents`` order), for the actions their ``masks`` allow."""
    if not hasattr(teacher, "values"):
        raise ValueError(
            f"{type(teacher).__name__} does not report its candidates' values: soft targets "
            "need a search teacher (imitate='lookahead')"
        )
    if teacher.values is None:
        return
    agent, values = teacher.values
    row = block.start + agents.index(agent)
    for action, makespan in values.items():
        if masks[row, action]:
            out[row, action] = makespan


def targets(values: np.ndarray | None, actions: np.ndarray, n_actions: int, tau: float,
            wait: bool = False) -> np.ndarray:  # fmt: skip
    """(rows, ``n_actions``) float32 target distributions: ``softmax(-(v - min v) / tau)``
    over a row's evaluated actions (finite ``values``; waiting, action 0, only where it is
    the label unless ``wait``) where its label is one of them, else the one-hot label;
    ``tau = 0`` or no ``values``: every row one-hot."""
    rows = np.arange(len(actions))
    out = np.zeros((len(actions), n_actions), dtype=np.float32)
    out[rows, actions] = 1.0
    if values is None or tau <= 0:
        return out
    if not wait:
        values = values.copy()
        values[actions != 0, 0] = np.nan
    soft = valued_rows(values, actions)
    v = values[soft].astype(np.float64)
    known = np.isfinite(v)
    best = np.where(known, v, np.inf).min(1, keepdims=True)
    weights = np.where(known, np.exp(-(np.where(known, v, best) - best) / tau), 0.0)
    out[soft] = weights / weights.sum(1, keepdims=True)
    return out


def valued_rows(values: np.ndarray, actions: np.ndarray) -> np.ndarray:
    """The rows whose label has a candidate value (the rows soft targets change)."""
    return np.isfinite(values[np.arange(len(actions)), actions])


def evaluate(policy, obs: th.Tensor, masks: np.ndarray) -> tuple[th.Tensor, th.Tensor]:
    """(values, every action's masked log-probability) in one pass: what a maskable
    actor-critic's ``evaluate_actions`` computes, for all actions at once."""
    from multicrane.training.set_policy import latents

    latent_pi, latent_vf = latents(policy, obs)
    distribution = policy._get_action_dist_from_latent(latent_pi)
    distribution.apply_masking(masks)
    return policy.value_net(latent_vf), distribution.distribution.logits


def actor_loss(policy, obs: th.Tensor, actions: np.ndarray, masks: np.ndarray,
               target: np.ndarray | None = None) -> tuple[th.Tensor, th.Tensor]:  # fmt: skip
    """(values, the actor's mean cross-entropy): against the labels ``actions`` (``target``
    None: ``evaluate_actions``' negative log-likelihood), else against the rows of
    ``target`` (``targets``)."""
    if target is None:
        values, log_prob, _ = policy.evaluate_actions(obs, th.as_tensor(actions),
                                                      action_masks=masks)  # fmt: skip
        return values, -log_prob.mean()
    values, log_probs = evaluate(policy, obs, masks)
    weights = th.as_tensor(target)
    # Masked actions have weight 0 (and a finite log-probability): no NaN from 0 * -inf.
    return values, -(weights * log_probs).sum(-1).mean()
