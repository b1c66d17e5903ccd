"""Imitation: a planner's choices fitted into a shared crane policy before PPO trains it.

PPO from random weights spends most of its budget rediscovering what a planner already knows
(which component next, which crane, which target), and on hall-4c it settles between the
greedy and the prioritized planner. Cloning a planner first starts PPO from the planner's
level instead (behaviour cloning; Pomerleau 1991, and the usual warm start of RL from
demonstrations).

- ``demonstrate`` plays ``episodes`` episodes of a teacher on the run's vector environment
  (a ``SetVecEnv`` for the set policy, a ``CraneVecEnv`` for the MLP at either decision
  level: the training run's own environments and reward, so the critic's targets are the
  learner's) and keeps every real crane row: the observation (padded for the set policy),
  the mask, the teacher's action and the discounted return that followed under the
  learner's (shaped) reward; with ``values=True`` also a search teacher's makespans of its
  candidates (``multicrane.training.soft_targets``).
- ``save`` / ``load`` keep them in a ``.npz`` file with what they were made for, so that
  several training seeds can share one (expensive) set of teacher episodes.
- ``multicrane.training.teaching.imitate`` is the step of a training run that uses them.
- ``clone`` fits the policy to them: cross-entropy of the teacher's actions under the masked
  logits (the actor) plus the squared error of the value on the returns, scaled by their
  variance (the critic, so that PPO's first updates do not start from a random baseline);
  with ``soft=tau``, cross-entropy against the soft targets of the rows' values instead.

A teacher is ``make_teacher(env, seed) -> policy`` with ``policy(observations) -> {agent:
action}`` for the run's ``MultiCraneEnv``, a policy of ``policies.factory`` such as
``"prioritized"`` (either decision level) or ``"lookahead"`` (task level) (``multicrane
train --imitate NAME`` passes it; this package never imports ``policies``). It is made for
each episode; planners read the environment's state, so the observations it gets hold only
each crane's ``action_mask``.
"""

from __future__ import annotations

import io
import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch as th

from multicrane.files import write_atomic, write_new_atomic
from multicrane.tasks.task_list import exclusive_masks, task_list
from multicrane.training import soft_targets

DEMO_STREAM = 2  # the demonstration copies' seed stream: [run seed, DEMO_STREAM]
STOP_CHECK = 10  # ``clone(stop_at=...)`` measures the agreement every this many epochs


@dataclass
class Demonstrations:
    """Rows of a teacher's episodes (one per real crane and decision round)."""

    observations: np.ndarray  # (R, observation size) float32 (set policy: padded, ``set_obs``)
    masks: np.ndarray  # (R, n_actions) bool
    actions: np.ndarray  # (R,) int64: the teacher's
    returns: np.ndarray  # (R,) float32: discounted return-to-go of the learner's reward
    makespans: list[int | None]  # per finished episode (None: hit the step limit)
    values: np.ndarray | None = None  # (R, n_actions) float32: candidates' makespans, else NaN

    def __len__(self) -> int:
        return len(self.actions)

    @property
    def decisions(self) -> np.ndarray:
        """Rows with a real choice (more than one allowed action)."""
        return self.masks.sum(1) > 1


class DemonstrationsError(ValueError):
    """A demonstrations file that cannot be used here; the message says why."""


ARRAYS = ("observations", "masks", "actions", "returns")


def save(demos: Demonstrations, path: str | Path, meta: dict, exclusive: bool = False) -> bool:
    """Write ``demos`` and ``meta`` (what they were made for: teacher, site, reward...) to a
    compressed ``.npz`` file, atomically. ``exclusive``: leave a file already at ``path`` as it
    is (another run wrote it first). True when this call wrote the file."""
    buffer = io.BytesIO()
    arrays = {name: getattr(demos, name) for name in ARRAYS}
    if demos.values is not None:
        arrays["values"] = demos.values
    makespans = [-1 if m is None else m for m in demos.makespans]
    np.savez_compressed(buffer, **arrays, makespans=np.array(makespans, dtype=np.int64),
                        meta=np.array(json.dumps(meta, sort_keys=True)))  # fmt: skip
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    if exclusive:
        return write_new_atomic(path, buffer.getvalue())
    write_atomic(path, buffer.getvalue())
    return True


def load(path: str | Path, meta: dict) -> Demonstrations:
    """The demonstrations of a file written by ``save`` for the same ``meta`` (the stored
    ``seed`` aside: any seed's teacher episodes serve, and a file with ``values`` serves a run
    that does not ask for them); ``DemonstrationsError`` names the file and what differs."""
    try:
        with np.load(path, allow_pickle=False) as data:
            stored = json.loads(str(data["meta"]))
            arrays = {name: data[name] for name in ARRAYS}
            arrays["values"] = data["values"] if "values" in data.files else None
            makespans = [None if m < 0 else int(m) for m in data["makespans"]]
    except (OSError, KeyError, ValueError) as exc:
        raise DemonstrationsError(f"{path}: not a demonstrations file ({exc})") from None
    ignore = {"seed"} | ({"values"} - set(meta))
    differ = sorted(k for k in set(stored) | set(meta)
                    if k not in ignore and stored.get(k) != meta.get(k))  # fmt: skip
    if differ:
        what = "; ".join(f"{k}: file {stored.get(k)!r} != run {meta.get(k)!r}" for k in differ)
        raise DemonstrationsError(f"{path}: demonstrations of another setting ({what})")
    return Demonstrations(**arrays, makespans=makespans)


def demonstration_seed(run_seed: int) -> int:
    """The seed of the demonstration copies: independent of the training copies' seeds."""
    return int(np.random.SeedSequence([int(run_seed), DEMO_STREAM]).generate_state(1)[0])


def demonstrate(venv, make_teacher: Callable, episodes: int, gamma: float,
                make_learner: Callable | None = None, values: bool = False,
                progress: Callable[[int], None] | None = None) -> Demonstrations:  # fmt: skip
    """``episodes`` finished teacher episodes on ``venv``'s copies (a ``CraneVecEnv`` or
    ``SetVecEnv``, seeded by the caller); episodes still running when the last one ends are
    left out. With ``make_learner(env, copy) -> act`` (made per episode; ``act(rows, masks)
    -> actions`` for the copy's real crane rows) the learner's actions are played and the
    teacher only labels the states they lead to (DAgger, ``multicrane.training.dagger``);
    the returns are then the learner's. ``values``: also keep the teacher's makespans of its
    candidates (``soft_targets.record``; a search teacher). ``progress(finished)`` is called
    each time an episode ends (a search teacher's episodes take seconds each)."""
    if episodes < 1:
        raise ValueError(f"episodes must be at least 1, got {episodes}")
    rows = venv.n_agents  # SB3 rows per copy (a SetVecEnv's spare rows included)
    obs = venv.reset()
    teachers: list = [None] * venv.n_copies
    learners: list = [None] * venv.n_copies
    log: list[tuple] = []  # per round: obs, masks, actions, rewards, dones, real rows
    valued: list[np.ndarray] | None = [] if values else None  # per round: candidates' values
    makespans: list[int | None] = []
    while len(makespans) < episodes:
        masks = venv.action_masks()
        actions = np.zeros(venv.num_envs, dtype=np.int64)
        played = actions if make_learner is None else np.zeros_like(actions)
        real = np.zeros(venv.num_envs, dtype=bool)
        grid = np.full(masks.shape, np.nan, dtype=np.float32) if values else None
        for c, env in enumerate(venv.envs):
            if teachers[c] is None:
                teachers[c] = make_teacher(env, None)
                learners[c] = make_learner and make_learner(env, c)
            joint = teachers[c]({a: {"action_mask": m} for a, m in env.action_masks().items()})
            block = slice(c * rows, c * rows + len(env.possible_agents))
            actions[block] = [joint[agent] for agent in env.possible_agents]
            real[block] = True
            if learners[c] is not None:  # before the labels' exclusive masks change ``masks``
                played[block] = learners[c](obs[block], masks[block])
            _exclusive(env, masks, actions, block)
            if values:
                soft_targets.record(teachers[c], env.possible_agents, masks, block, grid)
        venv.step_async(played)
        after, rewards, dones, infos = venv.step_wait()
        log.append((obs, masks, actions, rewards, dones, real))
        if values:
            valued.append(grid)
        for c in range(venv.n_copies):
            if dones[c * rows]:  # the copy's episode ended (and the copy was reset)
                info = infos[c * rows]
                makespans.append(info["episode"]["l"] if info["is_success"] else None)
                teachers[c] = learners[c] = None
                if progress is not None:
                    progress(len(makespans))
        obs = after
    return _rows(log, gamma, makespans[:episodes], valued)


def _exclusive(env, masks: np.ndarray, actions: np.ndarray, block: slice) -> None:
    """At the task level, the masks and actions of a copy's crane rows as the trained policy
    decides (``model_policy.exclusive_actions``; ``tasks.exclusive_masks``)."""
    tasks = task_list(env)
    if tasks is not None:
        masks[block], actions[block] = exclusive_masks(masks[block], actions[block], tasks)


def _rows(log: list[tuple], gamma: float, makespans: list,
          values: list[np.ndarray] | None = None) -> Demonstrations:  # fmt: skip
    """Discounted returns-to-go per row stream (backwards), then the real rows of finished
    episodes (and their ``values``, one array per round, if given)."""
    rewards = np.stack([x[3] for x in log])
    dones = np.stack([x[4] for x in log])
    keep = np.stack([x[5] for x in log])
    returns = np.zeros_like(rewards)
    g = np.zeros(rewards.shape[1], dtype=np.float64)
    ended = np.zeros(rewards.shape[1], dtype=bool)  # a done follows (the episode finished)
    for t in range(len(log) - 1, -1, -1):
        ended |= dones[t]
        g = rewards[t] + gamma * np.where(dones[t], 0.0, g)
        returns[t] = g
        keep[t] &= ended
    pick = keep.ravel()
    return Demonstrations(
        observations=np.concatenate([x[0] for x in log])[pick],
        masks=np.concatenate([x[1] for x in log])[pick],
        actions=np.concatenate([x[2] for x in log])[pick],
        returns=returns.ravel()[pick].astype(np.float32),
        makespans=makespans,
        values=None if values is None else np.concatenate(values)[pick],
    )


def clone(
    policy,
    demos: Demonstrations,
    epochs: int = 10,
    batch_size: int = 512,
    learning_rate: float = 1e-3,
    value_coef: float = 0.5,
    seed: int = 0,
    soft: float | None = None,
    stop_at: float | None = None,
) -> list[dict]:
    """Fit ``policy`` (a maskable actor-critic) to ``demos`` (see the module doc); one dict of
    losses per epoch, the last with ``agreement``: the share of decision rows whose greedy
    action is the teacher's. ``soft``: the temperature of soft targets over the rows'
    candidate values (``soft_targets.targets``; None: the teacher's actions). ``stop_at``:
    stop before ``epochs`` once that agreement reaches this share (checked every
    ``STOP_CHECK`` epochs; None: every epoch runs). A few decision rows that look alike to the
    network can take thousands of steps to separate: a large ``epochs`` with ``stop_at=1``
    fits a search's episode exactly without paying for the epochs it does not need."""
    if epochs < 1:
        raise ValueError(f"epochs must be at least 1, got {epochs}")
    if stop_at is not None and not 0 < stop_at <= 1:
        raise ValueError(f"stop_at must be a share in (0, 1], got {stop_at}")
    optimizer = th.optim.Adam(policy.parameters(), lr=learning_rate)
    scale = max(float(demos.returns.std()), 1.0) ** 2
    rng = np.random.default_rng([int(seed), DEMO_STREAM])
    n = len(demos)
    target = None
    if soft is not None:
        target = soft_targets.targets(demos.values, demos.actions, demos.masks.shape[1], soft)
    history = []
    policy.set_training_mode(True)
    for epoch in range(epochs):
        actor_sum = critic_sum = 0.0
        order = rng.permutation(n)
        for start in range(0, n, batch_size):
            idx = order[start : start + batch_size]
            obs = th.as_tensor(demos.observations[idx])
            batch_target = None if target is None else target[idx]
            values, actor = soft_targets.actor_loss(
                policy, obs, demos.actions[idx], demos.masks[idx], batch_target
            )
            critic = ((values.flatten() - th.as_tensor(demos.returns[idx])) ** 2).mean() / scale
            loss = actor + value_coef * critic
            optimizer.zero_grad()
            loss.backward()
            th.nn.utils.clip_grad_norm_(policy.parameters(), 0.5)
            optimizer.step()
            actor_sum += actor.item() * len(idx)
            critic_sum += critic.item() * len(idx)
        history.append({"epoch": epoch + 1, "actor_nll": actor_sum / n,
                        "critic_mse": critic_sum / n})  # fmt: skip
        if stop_at is not None and (epoch + 1) % STOP_CHECK == 0:
            policy.set_training_mode(False)
            if agreement(policy, demos) >= stop_at:
                break
            policy.set_training_mode(True)
    policy.set_training_mode(False)
    history[-1]["agreement"] = agreement(policy, demos)
    return history


def agreement(policy, demos: Demonstrations, batch_size: int = 1024) -> float:
    """The share of decision rows on which the policy's greedy action is the teacher's."""
    rows = np.flatnonzero(demos.decisions)
    if not len(rows):
        return 1.0
    same = 0
    with th.no_grad():
        for start in range(0, len(rows), batch_size):
            idx = rows[start : start + batch_size]
            dist = policy.get_distribution(th.as_tensor(demos.observations[idx]),
                                           action_masks=demos.masks[idx])  # fmt: skip
            greedy = dist.distribution.probs.argmax(-1).numpy()
            same += int((greedy == demos.actions[idx]).sum())
    return same / len(rows)
