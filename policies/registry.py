"""Policies by name, for the command-line programs: a built-in planner or a trained model.

``policy_factory(spec, paper)`` returns ``make_policy(env, seed)``; ``spec`` is ``optimal``
(paper mode only), ``greedy``, ``prioritized`` (multi-agent only), ``random``, or the path of
a training run directory (``tools/train.py``'s ``--out``) or of its ``model.zip``.
A policy's own random stream is seeded with ``[seed, 1]``: the environment's generator is
``default_rng(seed)``, and the same seed would make the policy repeat the layout's draws.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from policies.random_policy import RandomPolicy

PAPER_NAMES = ("optimal", "greedy", "random")
MULTI_NAMES = ("prioritized", "greedy", "random")


class PolicyError(ValueError):
    """A policy that cannot be used here; the message says why."""


class LazyOptimal:
    """The exact planner's episode, planned at the first call (right after the reset)."""

    def __init__(self, env):
        self.env = env
        self.actions: list[int] | None = None

    def __call__(self, observation=None) -> int:
        if self.actions is None:
            from policies.optimal import plan

            self.actions = list(plan(env=self.env.unwrapped).actions)
        return self.actions.pop(0) if self.actions else 0


def _uniform(seed: int) -> Callable:
    rng = RandomPolicy(seed=[seed, 1])
    mask = np.ones(6, dtype=np.int8)
    return lambda obs: rng.act(mask)


def policy_factory(spec: str, paper: bool) -> tuple[str, Callable]:
    """(label, make_policy(env, seed)) for ``spec``; see the module doc."""
    if paper:
        if spec == "optimal":
            return spec, lambda env, seed: LazyOptimal(env)
        if spec == "greedy":
            from policies.paper_greedy import PaperGreedyPolicy

            return spec, lambda env, seed: PaperGreedyPolicy(env)
        if spec == "random":
            return spec, lambda env, seed: _uniform(seed)
    else:
        if spec == "prioritized":
            from policies.prioritized import PrioritizedPlanner

            return spec, lambda env, seed: PrioritizedPlanner(env, seed=seed)
        if spec == "greedy":
            from policies.greedy import GreedyPolicy

            return spec, lambda env, seed: GreedyPolicy(env, seed=[seed, 1])
        if spec == "random":
            return spec, lambda env, seed: RandomPolicy(seed=[seed, 1])
    path = Path(spec)
    if not path.exists():
        names = PAPER_NAMES if paper else MULTI_NAMES
        raise PolicyError(
            f"policy {spec!r}: not one of {', '.join(names)} and no such run directory or model"
        )
    return model_factory(path, paper)


def model_factory(path: Path, paper: bool) -> tuple[str, Callable]:
    """A trained model (run directory or its ``model.zip``) as a policy factory."""
    from policies.learned import PaperModelPolicy, SharedModelPolicy, load_run

    run_dir = path.parent if path.suffix == ".zip" else path
    try:
        model, cfg = load_run(run_dir)
    except (FileNotFoundError, ValueError) as exc:
        raise PolicyError(f"policy {str(path)!r}: {exc}") from None
    if cfg.paper != paper:
        trained = "the single-agent benchmark mode" if cfg.paper else "the multi-agent mode"
        raise PolicyError(f"policy {str(path)!r} was trained in {trained} ({cfg.scenario})")
    label = f"{cfg.algo} ({run_dir.name})"
    wrapper = PaperModelPolicy if paper else SharedModelPolicy

    def make(env, seed):
        space = env.observation_space if paper else env.observation_space(env.possible_agents[0])
        shape = tuple((space if paper else space["observation"]).shape)
        if tuple(model.observation_space.shape) != shape:
            raise PolicyError(
                f"policy {str(path)!r} was trained on {cfg.scenario} with observations of shape "
                f"{tuple(model.observation_space.shape)}; this environment gives {shape}"
            )
        return wrapper(model, env)

    return label, make
