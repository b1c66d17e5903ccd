"""How much of a search teacher's departures from the planner's hint a set policy learns.

    PYTHONPATH=. python tools/departures.py TRAIN.npz HELDOUT.npz [--share S] [--epochs E]

Both files are demonstrations written by ``multicrane train --imitate ... --planner-hint
--imitate-demos FILE`` (the same set limits, the hint among them), the second from other
episodes (another ``--seed``). A fresh set policy (``SetPolicy``, the training runs' default
size) is fitted (``imitation.clone``) to a random share ``S`` of the first file's rows, then
its greedy choices are compared with the teacher's on the decision rows of both files, split
into the rows where the teacher takes the planner's proposed task (or waits when none is
proposed) and its *departures* from it. A policy that has learned when to depart learns them
on the held-out rows too; the share learned against ``S`` says whether more teacher episodes
would help (docs/marl-results.md, "The planner's hint").
"""

from __future__ import annotations

import argparse
import json

import numpy as np
import torch as th
from gymnasium import spaces

from multicrane.training.imitation import Demonstrations, clone, load
from multicrane.training.set_obs import N_TASK, SetLimits
from multicrane.training.set_policy import SetPolicy
from multicrane.training.set_training import SET_PPO


def read(path: str) -> tuple[Demonstrations, SetLimits]:
    with np.load(path, allow_pickle=False) as data:
        meta = json.loads(str(data["meta"]))
    limits = SetLimits(**meta["limits"])
    if not limits.hint:
        raise SystemExit(f"{path}: demonstrations without the planner's hint (--planner-hint)")
    return load(path, meta), limits


def proposed_actions(observations: np.ndarray, limits: SetLimits) -> np.ndarray:
    """The planner's proposal as an action of each row (1 + task; 0: wait, none proposed)."""
    start, end, shape = limits.slices()["tasks"]
    hint = observations[:, start:end].reshape(len(observations), *shape)[:, :, N_TASK]
    return np.where(hint.max(1) > 0.5, 1 + hint.argmax(1), 0)


def subset(demos: Demonstrations, share: float, seed: int) -> Demonstrations:
    if share >= 1:
        return demos
    rng = np.random.default_rng(seed)
    pick = np.sort(rng.choice(len(demos), max(1, int(share * len(demos))), replace=False))
    return Demonstrations(demos.observations[pick], demos.masks[pick], demos.actions[pick],
                          demos.returns[pick], demos.makespans)  # fmt: skip


def greedy(policy, demos: Demonstrations, rows: np.ndarray) -> np.ndarray:
    with th.no_grad():
        obs = th.as_tensor(demos.observations[rows])
        dist = policy.get_distribution(obs, action_masks=demos.masks[rows])
        return dist.distribution.logits.argmax(1).numpy()


def report(name: str, policy, demos: Demonstrations, limits: SetLimits) -> None:
    rows = np.flatnonzero(demos.decisions)
    chosen, teacher = greedy(policy, demos, rows), demos.actions[rows]
    departs = teacher != proposed_actions(demos.observations[rows], limits)
    same = chosen == teacher
    print(f"{name:<9} {len(rows):>8} {same.mean():>9.3f} {departs.sum():>10} "
          f"{same[departs].mean() if departs.any() else float('nan'):>8.3f} "
          f"{same[~departs].mean():>12.3f}")  # fmt: skip


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("train")
    p.add_argument("heldout")
    p.add_argument("--share", type=float, default=1.0, help="of the training rows (default 1)")
    p.add_argument("--epochs", type=int, default=30)
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args()
    th.set_num_threads(1)
    train, limits = read(args.train)
    heldout, other = read(args.heldout)
    if other != limits:
        raise SystemExit(f"{args.heldout}: set limits {other} differ from {limits}")
    train = subset(train, args.share, args.seed)
    th.manual_seed(args.seed)
    space = spaces.Box(-np.inf, np.inf, (limits.size,), np.float32)
    kwargs = {**SET_PPO["policy_kwargs"]["features_extractor_kwargs"], "limits": limits}
    policy = SetPolicy(space, spaces.Discrete(limits.n_actions), lambda _: 3e-4,
                       features_extractor_kwargs=kwargs)  # fmt: skip
    clone(policy, train, args.epochs, seed=args.seed)
    print(f"share {args.share} of the training rows, {args.epochs} epochs, seed {args.seed}")
    print(f"{'rows':<9} {'decided':>8} {'agreement':>9} {'departures':>10} {'learned':>8} "
          f"{'hint rows kept':>12}")  # fmt: skip
    report("training", policy, train, limits)
    report("held-out", policy, heldout, limits)


if __name__ == "__main__":
    main()
