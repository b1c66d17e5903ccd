"""Episode metrics for any policy of ``MultiCraneEnv``, and their aggregate over seeds.

    from policies.metrics import run_with_metrics, aggregate, evaluate
    m = run_with_metrics(env, policy, seed=0)        # one episode
    results, summary = evaluate("hall-4c", 4, lambda env, seed: PrioritizedPlanner(env),
                                seeds=range(5))

A *policy* is any callable ``policy(observations) -> {agent: action}`` (``GreedyPolicy``,
``PrioritizedPlanner``, ``RandomPolicy``, a trained network behind a wrapper).

Definitions (one episode; a *joint step* is one ``env.step`` call; the episode ends when the
building is complete or at the step limit):

- ``makespan``: joint steps to complete the building; ``None`` when the episode did not
  complete (``steps`` is then the step limit).
- ``crane_steps``: (crane, joint step) pairs in which the crane was busy: it held a
  component at the start of the step or at its end (claiming, carrying, waiting with a load,
  assembling). ``idle_crane_steps`` is the rest: ``n_cranes * steps - crane_steps``;
  ``utilisation`` their ratio ``crane_steps / (n_cranes * steps)``.
- ``blocked_moves``: ``BLOCKED`` events (a move refused because something was in the way,
  e.g. a component another crane moved earlier in the same step). ``failed_actions``:
  ``ILLEGAL``, ``CLAIM_CONFLICT`` and ``LIFT_BLOCKED`` events (actions that did nothing).
- ``plan_ms_per_step``: wall time spent inside the policy call, in milliseconds, divided by
  the number of calls (one call decides the joint action of all cranes, so this is the
  planning time per joint decision); ``plan_ms_per_crane`` divides the same total by
  ``steps * n_cranes`` (per crane decision); ``plan_ms_max`` is the slowest single call.
- ``return``: the team return (sum of the team reward).
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable, Iterable
from typing import Any

from multicrane.simulator import NOBODY
from multicrane.types import EventType
from policies.evaluation import sem

_FAILED = (EventType.ILLEGAL, EventType.CLAIM_CONFLICT, EventType.LIFT_BLOCKED)


def run_with_metrics(env, policy: Callable[[dict], dict], seed: int | None = None) -> dict:
    """Play one episode from ``env.reset(seed=seed)`` and measure it (see the module doc)."""
    observations, _ = env.reset(seed=seed)
    sim = env.sim
    n = sim.n_cranes
    agents = env.possible_agents
    first = agents[0]
    steps = busy = blocked = failed = 0
    total = 0.0
    plan_s = plan_max = 0.0
    events = dict.fromkeys((e.name for e in EventType), 0)
    while env.agents:
        held_before = [c != NOBODY for c in sim.held]
        start = time.perf_counter()
        actions = policy(observations)
        spent = time.perf_counter() - start
        plan_s += spent
        plan_max = max(plan_max, spent)
        observations, rewards, terminations, truncations, infos = env.step(actions)
        steps += 1
        total += rewards[first]
        busy += sum(1 for i in range(n) if held_before[i] or sim.held[i] != NOBODY)
        for a in agents:
            for e in infos[a]["events"]:
                events[e.type.name] += 1
                if e.type == EventType.BLOCKED:
                    blocked += 1
                elif e.type in _FAILED:
                    failed += 1
        if terminations[first] or truncations[first]:
            break
    success = bool(sim.done)
    return {
        "scenario": env.scenario.name,
        "n_cranes": n,
        "seed": seed,
        "success": success,
        "makespan": steps if success else None,
        "steps": steps,
        "return": total,
        "crane_steps": busy,
        "idle_crane_steps": n * steps - busy,
        "utilisation": busy / (n * steps) if steps else 0.0,
        "blocked_moves": blocked,
        "failed_actions": failed,
        "events": events,
        "plan_seconds": plan_s,
        "plan_ms_per_step": 1000.0 * plan_s / steps if steps else 0.0,
        "plan_ms_per_crane": 1000.0 * plan_s / (steps * n) if steps else 0.0,
        "plan_ms_max": 1000.0 * plan_max,
    }


def aggregate(results: Iterable[dict]) -> dict[str, Any]:
    """Summary over episodes (usually seeds of one scenario, crane count and policy).

    ``makespan_*`` are over the completed episodes only (``None`` when none completed);
    ``success_rate`` says how many those are. The other means are over all episodes. The
    planning times are pooled: total policy time over total joint steps (or crane decisions);
    ``plan_ms_max`` is the slowest call of any episode.
    """
    rs = list(results)
    if not rs:
        raise ValueError("aggregate() needs at least one episode")
    done = [r["makespan"] for r in rs if r["success"]]
    steps = sum(r["steps"] for r in rs)
    decisions = sum(r["steps"] * r["n_cranes"] for r in rs)
    plan_s = sum(r["plan_seconds"] for r in rs)
    return {
        "episodes": len(rs),
        "success_rate": len(done) / len(rs),
        "makespan_mean": statistics.fmean(done) if done else None,
        "makespan_sem": sem(done) if done else None,
        "makespan_min": min(done) if done else None,
        "makespan_max": max(done) if done else None,
        "steps_mean": statistics.fmean(r["steps"] for r in rs),
        "return_mean": statistics.fmean(r["return"] for r in rs),
        "crane_steps_mean": statistics.fmean(r["crane_steps"] for r in rs),
        "idle_crane_steps_mean": statistics.fmean(r["idle_crane_steps"] for r in rs),
        "utilisation_mean": statistics.fmean(r["utilisation"] for r in rs),
        "blocked_moves_mean": statistics.fmean(r["blocked_moves"] for r in rs),
        "failed_actions_mean": statistics.fmean(r["failed_actions"] for r in rs),
        "plan_ms_per_step": 1000.0 * plan_s / steps if steps else 0.0,
        "plan_ms_per_crane": 1000.0 * plan_s / decisions if decisions else 0.0,
        "plan_ms_max": max(r["plan_ms_max"] for r in rs),
    }


def evaluate(
    scenario,
    n_cranes: int | None,
    make_policy: Callable[[Any, int], Callable[[dict], dict]],
    seeds: Iterable[int],
    **env_options,
) -> tuple[list[dict], dict[str, Any]]:
    """Run ``make_policy(env, seed)`` on ``reset(seed=seed)`` for each seed; a fresh policy
    per episode, one environment for all. Returns the per-episode results and
    ``aggregate`` of them."""
    from multicrane import parallel_env

    env = parallel_env(scenario, n_cranes=n_cranes, **env_options)
    results = [run_with_metrics(env, make_policy(env, seed), seed=seed) for seed in seeds]
    return results, aggregate(results)
