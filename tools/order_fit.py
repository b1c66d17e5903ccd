"""Can a site's static features give a planner's start order? A scorer fitted to it, then played.

    .venv/bin/python tools/order_fit.py --fit set:test-small --play set:test-small --epochs 1000

Plays ``--policy`` (one episode per site of ``--fit``, reset seed ``--seed``) and keeps its
start order (``tools/order_probe.py``); fits a scorer of each component's static features
(below), a two-layer MLP trained so that a component started earlier scores higher (the
logistic loss over every ordered pair of a site, ``--epochs`` passes, Adam at 3e-3, torch on
one thread, ``--seed`` for its weights); then plays the prioritized rule on every site of
``--play`` with the components in score order as its list order
(``TaskPrioritized(order=...)``). Prints the pairwise agreement of the scores with the fitted
orders and the mean makespan. With ``--play`` the same set as ``--fit``, the figure is an
upper bound: the scorer has seen those very orders.

The features are ``multicrane.tasks.order_scorer.FEATURES``. Needs the ``train`` extra (torch).
"""

from __future__ import annotations

import argparse
import statistics
import sys
from pathlib import Path

import numpy as np

import multicrane
import policies
from multicrane.episodes.rollout import run_episode
from multicrane.scenario.named_sets import resolve_set
from multicrane.tasks.order_scorer import component_features as features_of
from policies.task_planners import TaskPrioritized

sys.path.insert(0, str(Path(__file__).parent))  # tools/ is not a package
from order_probe import start_order  # noqa: E402


def component_features(env) -> np.ndarray:
    """(C, len(FEATURES)) float32: every component's static features (``order_scorer``)."""
    base = env.unwrapped
    return features_of(base.mode.task_book(), base.scenario)


def collect(sites, spec: str, seed: int) -> list[tuple[np.ndarray, list[int]]]:
    """Per site: the features and the policy's start order."""
    out = []
    for _, scenario in sites:
        env = multicrane.parallel_env(scenario, decisions="task")
        played = run_episode(env, policies.make(spec, env, seed=seed), seed, record=True)
        out.append((component_features(env), start_order(env, played["actions"])))
    return out


def earlier(order: list[int]) -> np.ndarray:
    """(C, C) bool: component ``a`` comes before ``b`` in ``order``."""
    place = np.empty(len(order), dtype=np.int64)
    place[order] = np.arange(len(order))
    return place[:, None] < place[None, :]


def fit(data, epochs: int, seed: int):
    """The scorer (module doc) fitted to the start orders; returns ``features -> scores``."""
    import torch

    torch.set_num_threads(1)
    torch.manual_seed(seed)
    width = 64
    net = torch.nn.Sequential(
        torch.nn.Linear(data[0][0].shape[1], width), torch.nn.ReLU(),
        torch.nn.Linear(width, width), torch.nn.ReLU(), torch.nn.Linear(width, 1),
    )  # fmt: skip
    optimiser = torch.optim.Adam(net.parameters(), lr=3e-3)
    pairs = []
    for features, order in data:
        first = torch.tensor(earlier(order), dtype=torch.float32)
        pairs.append((torch.tensor(features), first))
    for _ in range(epochs):
        for features, first in pairs:
            scores = net(features).squeeze(-1)
            margin = scores[:, None] - scores[None, :]
            loss = (torch.nn.functional.softplus(-margin) * first).sum() / first.sum()
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()

    def score(features: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            return net(torch.tensor(features)).squeeze(-1).numpy()

    return score


def agreement(score, data) -> float:
    """The share of ordered pairs the scores put in the start order's order."""
    right = total = 0
    for features, order in data:
        s, first = score(features), earlier(order)
        right += int(((s[:, None] > s[None, :]) & first).sum())
        total += int(first.sum())
    return right / max(total, 1)


def play(score, sites, seed: int) -> list[int | None]:
    """The rule's makespan on each site with the components in score order."""
    spans = []
    for _, scenario in sites:
        env = multicrane.parallel_env(scenario, decisions="task")
        env.reset(seed=seed)
        order = np.argsort(-score(component_features(env)), kind="stable").tolist()
        spans.append(run_episode(env, TaskPrioritized(env, order=order), seed)["makespan"])
    return spans


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--fit", default="set:test-small", help="set:NAME whose orders are fitted")
    parser.add_argument("--play", default="set:test-small", help="set:NAME played")
    parser.add_argument("--policy", default="lookahead:rank=chain", help="whose order")
    parser.add_argument("--epochs", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=1_000_000, help="reset seed; scorer seed")
    args = parser.parse_args(argv)
    data = collect(resolve_set(args.fit), args.policy, args.seed)
    score = fit(data, args.epochs, args.seed)
    spans = play(score, resolve_set(args.play), args.seed)
    done = [s for s in spans if s is not None]
    print(f"pairwise agreement with the fitted orders: {agreement(score, data):.3f}")
    print(f"{args.play}: mean makespan {statistics.fmean(done):.1f} over {len(done)} finished "
          f"of {len(spans)} sites")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
