"""Exclusive claims in PPO's rollouts: the crane rows of a copy sample one after the other.

Deployed, the set policy's cranes claim tasks in turn (``model_policy.exclusive_actions``):
each task a crane takes removes the tasks it conflicts with (the same component or the same
target, ``multicrane.tasks.book.TaskList.conflicts``) from the later cranes' masks. MaskablePPO
samples every row on its own instead, so two idle cranes that see the same state pick the
same task, the environment refuses the later one (it waits), and PPO credits the wait's
outcome to a task choice the deployed policy would never make. ``claim_in_turn`` samples as
deployed: row ``k`` of a copy under its mask less the conflicts of rows ``0..k-1``'s choices,
and returns the masks each row saw, so that PPO's update evaluates every action under the mask
it was drawn from.

The conflicts are read from the padded observation (``multicrane.training.set_obs``), so that
copies in other processes need not be asked: a task's component is its ``component`` column
(times ``C - 1``), its target the six target-node columns (two tasks with the same nodes have
the same target on every shipped and generated site; the tests check it).
"""

from __future__ import annotations

import torch as th

from multicrane.training.set_obs import SetLimits

_COMPONENT, _TARGET = 0, slice(1, 7)  # task columns: component index, target nodes


def claim_in_turn(obs: th.Tensor, logits: th.Tensor, masks: th.Tensor, limits: SetLimits,
                  rows: int, deterministic: bool = False
                  ) -> tuple[th.Tensor, th.Tensor]:  # fmt: skip
    """(actions, masks as each row saw them) of a batch of ``rows`` crane rows per copy, copy
    after copy (``obs``: padded observations, ``logits``/``masks``: (B, 1 + P)). A row left with
    no allowed action waits (as the environment would have it)."""
    B, A = logits.shape
    if B % rows:
        raise ValueError(f"{B} rows are not whole copies of {rows} crane rows")
    start, end, shape = limits.slices()["tasks"]
    tasks = obs[:, start:end].reshape(B // rows, rows, *shape)
    n_comp = (obs[:, 0].reshape(B // rows, rows) - 1).clamp(min=1)
    component = (tasks[..., _COMPONENT] * n_comp[..., None]).round()  # (copies, rows, P)
    target = tasks[..., _TARGET]  # (copies, rows, P, 6)
    seen = masks.reshape(B // rows, rows, A).clone()
    scores = logits.reshape(B // rows, rows, A)
    actions = th.zeros(B // rows, rows, dtype=th.long)
    copies = th.arange(B // rows)
    for k in range(rows):
        seen[:, k, 0] |= ~seen[:, k].any(-1)
        row = scores[:, k].masked_fill(~seen[:, k], -th.inf)
        if deterministic:
            chosen = row.argmax(-1)
        else:
            chosen = th.distributions.Categorical(logits=row).sample()
        actions[:, k] = chosen
        if k + 1 == rows:
            break
        p = (chosen - 1).clamp(min=0)
        same = component[:, k] == component[copies, k, p][:, None]
        same |= (target[:, k] == target[copies, k, p][:, None, :]).all(-1)
        same &= (chosen > 0)[:, None]
        seen[:, k + 1 :, 1 : 1 + shape[0]] &= ~same[:, None, :]
    return actions.reshape(B), seen.reshape(B, A)
