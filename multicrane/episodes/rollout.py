"""Run a policy: the one episode loop, evaluation over seeds and the summary, for both modes.

    from multicrane.episodes.rollout import evaluate, run_episode, summarise
    m = run_episode(env, policy, seed=0)                         # one episode
    episodes, summary = evaluate(env, make_policy, seeds=range(5))

The environment is either the multi-agent ``ParallelEnv`` (``MultiCraneEnv``), where a policy
is called as ``policy(observations) -> {agent: action}``, or the single-agent benchmark env
(``PaperAssemblyEnv``, possibly behind Gymnasium wrappers), where it is called as
``policy(observation) -> action``. ``make_policy(env, seed)`` builds a fresh policy for each
episode (``policies.factory(name)`` gives one for a policy by name). This module never
imports ``policies``: the caller passes the policy in.

Definitions (one episode; a *step* is one simulated step: one ``env.step`` call, a joint
step, in the multi-agent motion mode; with ``decisions="task"`` one call may advance several
simulated steps, counted by the simulator's step count; the episode ends when the building
is complete or at the step limit):

- ``return``: the sum of the (team) reward. ``success``: the building was completed.
- ``steps``: the steps played; ``makespan``: the steps to complete the building, ``None``
  when the episode did not complete (``steps`` is then the step limit).
- ``crane_steps``: (crane, step) pairs in which the crane was busy: it held a component at
  the start of the step or at its end (claiming, carrying, waiting with a load, assembling).
  ``idle_crane_steps`` is the rest: ``n_cranes * steps - crane_steps``; ``utilisation``
  their ratio ``crane_steps / (n_cranes * steps)``.
- ``blocked_moves``: ``BLOCKED`` events (a move refused because something was in the way,
  e.g. a component another crane moved earlier in the same step). ``failed_actions``:
  ``ILLEGAL``, ``CLAIM_CONFLICT`` and ``LIFT_BLOCKED`` events (actions that did nothing).
  ``events``: the count of every event type.
- ``plan_seconds``: wall time spent inside the policy calls. ``plan_ms_per_step``: that time
  in milliseconds divided by the number of calls (one call decides the joint action of all
  cranes, so this is the planning time per joint decision); ``plan_ms_per_crane`` divides
  the same total by ``steps * n_cranes`` (per crane decision); ``plan_ms_max`` is the
  slowest single call. In task mode the result also holds ``decision_rounds`` (the policy
  calls), ``plan_ms_per_step`` is per decision round, and ``crane_steps`` comes from the
  environment's ``infos`` (busy crane x simulated step pairs).

The summary of a set of episodes (``summarise``): ``return_mean`` and its standard error
``return_sem`` (``multicrane.stats.sem``: None for one episode), ``success_rate``,
``steps_mean`` (all episodes; unfinished ones count the step limit) and
``finish_steps_mean`` (finished episodes only); for episodes that carry the metrics above,
``makespan_mean``/``_sem``/``_min``/``_max`` over the completed episodes (``None`` when none
completed), the means of ``crane_steps``, ``idle_crane_steps``, ``utilisation``,
``blocked_moves`` and ``failed_actions`` over all episodes, and the planning times pooled
(total policy time over total steps or crane decisions; ``plan_ms_max`` the slowest call of
any episode). With the exact planner's returns on the same seeds (``optimal``, e.g.
``optimal_returns``): ``optimal_mean``, ``gap`` = optimal - return (>= 0) and ``gap_pct`` =
gap / |optimal| in percent.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable, Iterable
from typing import Any

from multicrane.core.codes import EventType
from multicrane.sim.simulator import NOBODY
from multicrane.stats import sem

_FAILED = (EventType.ILLEGAL, EventType.CLAIM_CONFLICT, EventType.LIFT_BLOCKED)

OnReset = Callable[[Any], None]
OnStep = Callable[[Any, Any, float, dict], None]


def is_multi_agent(env) -> bool:
    """True for a PettingZoo ``ParallelEnv`` (it has ``possible_agents``)."""
    return hasattr(env, "possible_agents")


def run_episode(
    env,
    policy: Callable,
    seed: int | None = None,
    *,
    record: bool = False,
    on_reset: OnReset | None = None,
    on_step: OnStep | None = None,
) -> dict[str, Any]:
    """Play one episode from ``env.reset(seed=seed)`` and measure it (see the module doc).

    ``on_reset(env)`` is called after the reset; ``on_step(env, action, reward, info)`` after
    every step, with the joint action as a list in agent order (multi-agent mode; ``info`` is
    then the dict of every agent's info) or the action (single-agent mode). With ``record``
    the result also holds ``actions``: one entry per step, in that same form.
    """
    if is_multi_agent(env):
        return _multi_agent(env, policy, seed, record, on_reset, on_step)
    return _single_agent(env, policy, seed, record, on_reset, on_step)


class _Tally:
    """Counters of one episode, turned into the result dict at the end."""

    def __init__(self, n_cranes: int):
        self.n = n_cranes
        self.steps = self.calls = self.busy = self.blocked = self.failed = 0
        self.total = 0.0
        self.plan_s = self.plan_max = 0.0
        self.events = dict.fromkeys((e.name for e in EventType), 0)
        self.actions: list = []

    def timed(self, policy: Callable, observation) -> Any:
        start = time.perf_counter()
        action = policy(observation)
        spent = time.perf_counter() - start
        self.plan_s += spent
        self.plan_max = max(self.plan_max, spent)
        return action

    def count(self, events: Iterable) -> None:
        for e in events:
            self.events[e.type.name] += 1
            if e.type == EventType.BLOCKED:
                self.blocked += 1
            elif e.type in _FAILED:
                self.failed += 1

    def result(self, scenario: str, seed: int | None, success: bool, record: bool) -> dict:
        n, steps, plan_s = self.n, self.steps, self.plan_s
        out = {
            "scenario": scenario,
            "n_cranes": n,
            "seed": seed,
            "success": success,
            "makespan": steps if success else None,
            "steps": steps,
            "return": self.total,
            "crane_steps": self.busy,
            "idle_crane_steps": n * steps - self.busy,
            "utilisation": self.busy / (n * steps) if steps else 0.0,
            "blocked_moves": self.blocked,
            "failed_actions": self.failed,
            "events": self.events,
            "plan_seconds": plan_s,
            "plan_ms_per_step": 1000.0 * plan_s / steps if steps else 0.0,
            "plan_ms_per_crane": 1000.0 * plan_s / (steps * n) if steps else 0.0,
            "plan_ms_max": 1000.0 * self.plan_max,
        }
        if record:
            out["actions"] = self.actions
        return out


def _multi_agent(env, policy, seed, record, on_reset, on_step) -> dict[str, Any]:
    observations, _ = env.reset(seed=seed)
    base = env.unwrapped
    sim = base.sim
    n = sim.n_cranes
    agents = env.possible_agents
    first = agents[0]
    tally = _Tally(n)
    if on_reset is not None:
        on_reset(env)
    start = sim.state.step_count
    while env.agents:
        held_before = [c != NOBODY for c in sim.state.held]
        actions = tally.timed(policy, observations)
        observations, rewards, terminations, truncations, infos = env.step(actions)
        reward = float(rewards[first])
        tally.calls += 1
        tally.steps = sim.state.step_count - start  # simulated steps (task mode: several)
        tally.total += reward
        if "crane_steps" in infos[first]:
            tally.busy += infos[first]["crane_steps"]
        else:
            tally.busy += sum(
                1 for i in range(n) if held_before[i] or sim.state.held[i] != NOBODY
            )
        for crane_events in base.last_events:
            tally.count(crane_events)
        if record or on_step is not None:
            joint = [int(actions[a]) for a in agents]
            if record:
                tally.actions.append(joint)
            if on_step is not None:
                on_step(env, joint, reward, infos)
        if terminations[first] or truncations[first]:
            break
    out = tally.result(base.scenario.name, seed, bool(sim.done), record)
    if getattr(base, "decisions", "motion") == "task":
        out["decision_rounds"] = tally.calls
        out["plan_ms_per_step"] = 1000.0 * tally.plan_s / tally.calls if tally.calls else 0.0
    return out


def _single_agent(env, policy, seed, record, on_reset, on_step) -> dict[str, Any]:
    observation, _ = env.reset(seed=seed)
    base = env.unwrapped
    sim = base.sim
    tally = _Tally(sim.n_cranes)
    if on_reset is not None:
        on_reset(env)
    while True:
        held_before = sim.state.held[0] != NOBODY
        action = tally.timed(policy, observation)
        observation, reward, terminated, truncated, info = env.step(action)
        reward = float(reward)
        tally.steps += 1
        tally.total += reward
        tally.busy += 1 if held_before or sim.state.held[0] != NOBODY else 0
        tally.count(base.last_events)
        if record:
            tally.actions.append(int(action))
        if on_step is not None:
            on_step(env, action, reward, info)
        if terminated or truncated:
            return tally.result(base.scenario.name, seed, bool(terminated), record)


def evaluate(
    env,
    make_policy: Callable[[Any, int], Callable],
    seeds: Iterable[int],
    progress: Callable[[list[int]], Iterable[int]] | None = None,
    *,
    optimal: list[float] | None = None,
) -> tuple[list[dict], dict[str, Any]]:
    """Episodes of ``make_policy(env, seed)`` (a fresh policy per episode, one environment
    for all) on each seed, and their ``summarise`` (with the gap to ``optimal``, the exact
    planner's returns on the same seeds, when given). ``progress`` wraps the list of seeds,
    e.g. in a progress bar."""
    seeds = list(seeds)
    todo = progress(seeds) if progress is not None else seeds
    episodes = [run_episode(env, make_policy(env, s), seed=s) for s in todo]
    return episodes, summarise(episodes, optimal)


def optimal_returns(env, seeds: Iterable[int]) -> list[float]:
    """The exact planner's return on each seed of a single-agent env's scenario
    (``multicrane.bounds.paper_optimum``); the env is left reset to the last seed."""
    from multicrane.bounds.paper_optimum import plan

    base = env.unwrapped
    out = []
    for s in seeds:
        base.reset(seed=s)
        out.append(plan(env=base).episode_return)
    return out


def summarise(episodes: list[dict], optimal: list[float] | None = None) -> dict[str, Any]:
    """The summary of a set of episodes (see the module doc)."""
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
    if all("crane_steps" in e for e in episodes):
        out.update(_metrics(episodes))
    if optimal is not None:
        best = statistics.fmean(optimal)
        gap = best - out["return_mean"]
        out.update(optimal_mean=best, gap=gap, gap_pct=100.0 * gap / abs(best) if best else None)
    return out


def _metrics(rs: list[dict]) -> dict[str, Any]:
    """The means of ``run_episode``'s metrics over episodes (see the module doc)."""
    done = [r["makespan"] for r in rs if r["success"]]
    steps = sum(r["steps"] for r in rs)
    decisions = sum(r["steps"] * r["n_cranes"] for r in rs)
    plan_s = sum(r["plan_seconds"] for r in rs)
    return {
        "makespan_mean": statistics.fmean(done) if done else None,
        "makespan_sem": sem(done),
        "makespan_min": min(done) if done else None,
        "makespan_max": max(done) if done else None,
        "crane_steps_mean": statistics.fmean(r["crane_steps"] for r in rs),
        "idle_crane_steps_mean": statistics.fmean(r["idle_crane_steps"] for r in rs),
        "utilisation_mean": statistics.fmean(r["utilisation"] for r in rs),
        "blocked_moves_mean": statistics.fmean(r["blocked_moves"] for r in rs),
        "failed_actions_mean": statistics.fmean(r["failed_actions"] for r in rs),
        "plan_ms_per_step": 1000.0 * plan_s / steps if steps else 0.0,
        "plan_ms_per_crane": 1000.0 * plan_s / decisions if decisions else 0.0,
        "plan_ms_max": max(r["plan_ms_max"] for r in rs),
    }
