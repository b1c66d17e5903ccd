"""Evaluate any policy on seeds of one scenario, in either mode, and summarise.

A *paper-mode policy* is made per episode by ``make_policy(env, seed)`` and called as
``policy(observation) -> action`` (``PaperGreedyPolicy``, ``PlanPolicy``, a trained model
behind ``policies.learned``). A *multi-agent policy* is called as
``policy(observations) -> {agent: action}`` (see ``policies.metrics``).

The summary of a set of episodes: ``return_mean`` and its standard error over episodes,
``success_rate``, ``steps_mean`` (all episodes; unfinished ones count the step limit) and
``finish_steps_mean`` (finished episodes only), and in paper mode ``optimal_mean`` (the exact
planner's return on the same seeds) with ``gap`` = optimal - return (>= 0) and ``gap_pct`` =
gap / |optimal| in percent.
"""

from __future__ import annotations

import statistics
from collections.abc import Callable, Iterable
from typing import Any

from multicrane.paper_env import PaperAssemblyEnv


def sem(values: list[float]) -> float:
    """Standard error of the mean (0 for fewer than two values)."""
    return statistics.stdev(values) / len(values) ** 0.5 if len(values) > 1 else 0.0


def run_paper_episode(env: PaperAssemblyEnv, policy: Callable, seed: int | None) -> dict:
    """One episode of a paper-mode policy from ``env.reset(seed=seed)``."""
    obs, _ = env.reset(seed=seed)
    total, steps = 0.0, 0
    while True:
        obs, reward, terminated, truncated, _ = env.step(policy(obs))
        total += float(reward)
        steps += 1
        if terminated or truncated:
            return {"seed": seed, "return": total, "success": bool(terminated), "steps": steps}


def evaluate_paper(
    env: PaperAssemblyEnv,
    make_policy: Callable[[PaperAssemblyEnv, int], Callable],
    seeds: Iterable[int],
    optimal: bool = True,
) -> tuple[list[dict], dict[str, Any]]:
    """Episodes of ``make_policy(env, seed)`` on each seed, and their summary (with the gap
    to the exact planner's return on the same seeds when ``optimal``)."""
    episodes = [run_paper_episode(env, make_policy(env, s), s) for s in seeds]
    best = optimal_returns(env, [e["seed"] for e in episodes]) if optimal else None
    return episodes, summarise(episodes, best)


def optimal_returns(env: PaperAssemblyEnv, seeds: Iterable[int]) -> list[float]:
    """The exact planner's return on each seed, for the environment's scenario."""
    from policies.optimal import plan

    out = []
    for s in seeds:
        env.reset(seed=s)
        out.append(plan(env=env).episode_return)
    return out


def summarise(episodes: list[dict], optimal: list[float] | None = None) -> dict[str, Any]:
    if not episodes:
        raise ValueError("summarise() needs at least one episode")
    returns = [e["return"] for e in episodes]
    finished = [e["steps"] for e in episodes if e["success"]]
    out: dict[str, Any] = {
        "episodes": len(episodes),
        "return_mean": statistics.fmean(returns),
        "return_sem": sem(returns),
        "success_rate": len(finished) / len(episodes),
        "steps_mean": statistics.fmean(e["steps"] for e in episodes),
        "finish_steps_mean": statistics.fmean(finished) if finished else None,
    }
    if optimal is not None:
        best = statistics.fmean(optimal)
        gap = best - out["return_mean"]
        out.update(optimal_mean=best, gap=gap, gap_pct=100.0 * gap / abs(best) if best else None)
    return out


def evaluate_multi(
    env, make_policy: Callable[[Any, int], Callable], seeds: Iterable[int]
) -> tuple[list[dict], dict[str, Any]]:
    """Episodes of a multi-agent policy (``policies.metrics.run_with_metrics``) and their
    summary (``summarise``, plus the mean makespan and blocked moves)."""
    from policies.metrics import aggregate, run_with_metrics

    episodes = [run_with_metrics(env, make_policy(env, s), seed=s) for s in seeds]
    summary = summarise(episodes)
    extra = aggregate(episodes)
    summary.update(
        makespan_mean=extra["makespan_mean"],
        blocked_moves_mean=extra["blocked_moves_mean"],
        failed_actions_mean=extra["failed_actions_mean"],
    )
    return episodes, summary
