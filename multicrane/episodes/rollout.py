"""Run a policy: the one episode loop, evaluation over seeds and the summary, for both modes.

    from multicrane.episodes.rollout import evaluate, run_episode, summarise
    m = run_episode(env, policy, seed=0)                         # one episode
    episodes, summary = evaluate(env, make_policy, seeds=range(5))

``play`` is the one episode loop (``run_episode`` measures an episode through its hooks; the
throughput and cost programs call it directly): it plays a policy to the end of an episode,
for a number of steps, or for exactly that many steps over as many episodes as it takes,
``play_seeds`` over episodes on seeds 0, 1, ...; a ``Stopwatch`` passed as ``step_watch``
times the ``env.step`` calls and nothing else, one wrapped around the policy its calls only.

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
AfterStep = Callable[[Any, tuple], None]


def is_multi_agent(env) -> bool:
    """True for a PettingZoo ``ParallelEnv`` (it has ``possible_agents``)."""
    return hasattr(env, "possible_agents")


class Stopwatch:
    """The seconds of each call it times, by one clock (``time.perf_counter`` unless given,
    e.g. ``time.process_time`` for CPU time): ``watch.timing(fn)`` is ``fn`` timed."""

    def __init__(self, clock: Callable[[], float] = time.perf_counter):
        self.clock = clock
        self.seconds: list[float] = []

    def timing(self, fn: Callable) -> Callable:
        """``fn``, appending the seconds of each call (of that call only) to ``seconds``."""
        clock, seconds = self.clock, self.seconds

        def timed(*args, **kwargs):
            start = clock()
            out = fn(*args, **kwargs)
            seconds.append(clock() - start)
            return out

        return timed


def play(
    env,
    policy: Callable,
    seed: int | None = None,
    *,
    steps: int | None = None,
    repeat: bool = False,
    step_watch: Stopwatch | None = None,
    on_reset: OnReset | None = None,
    after_step: AfterStep | None = None,
) -> int:
    """The one episode loop: play ``policy`` from ``env.reset(seed=seed)`` to the end of the
    episode or for at most ``steps`` ``env.step`` calls; with ``repeat``, for exactly ``steps``
    calls, resetting (``env.reset()``: the environment's random stream goes on) whenever an
    episode ends. Returns the ``env.step`` calls made.

    Hooks, free when not given: ``step_watch`` times each ``env.step`` call and nothing else
    (time the policy by passing ``watch.timing(policy)``); ``on_reset(env)`` runs after each
    reset; ``after_step(action, out)`` after each step, with the action sent and the tuple
    ``env.step`` returned.
    """
    if repeat and steps is None:
        raise ValueError("play(repeat=True) needs a number of steps")
    step = env.step if step_watch is None else step_watch.timing(env.step)
    multi = is_multi_agent(env)
    observation = _reset(env, seed, on_reset)
    made = 0
    while steps is None or made < steps:
        action = policy(observation)
        out = step(action)
        made += 1
        if after_step is not None:
            after_step(action, out)
        if (not env.agents) if multi else (out[2] or out[3]):
            if not repeat:
                break
            observation = _reset(env, None, on_reset)
        else:
            observation = out[0]
    return made


def _reset(env, seed: int | None, on_reset: OnReset | None):
    """Reset ``env`` with ``seed``, run ``on_reset(env)``, return the reset's observation."""
    observation, _ = env.reset(seed=seed)
    if on_reset is not None:
        on_reset(env)
    return observation


def play_seeds(env, make_policy: Callable[[Any, int], Callable], steps: int, **hooks) -> int:
    """Episodes on seeds 0, 1, ... (``make_policy(env, seed)`` plays each) until ``steps``
    ``env.step`` calls in all, the last episode cut short; ``hooks`` as for ``play``.
    Returns the episodes played."""
    made = seed = 0
    while made < steps:
        made += play(env, make_policy(env, seed), seed, steps=steps - made, **hooks)
        seed += 1
    return seed


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
    """Counters of one episode, kept by ``play``'s hooks, turned into the result dict at the
    end: ``decide`` is the policy ``play`` calls, ``started`` its ``on_reset``."""

    def __init__(self, base, policy: Callable, on_reset: OnReset | None):
        self.sim = base.sim
        self.n = self.sim.n_cranes
        self.steps = self.calls = self.busy = self.blocked = self.failed = self.start = 0
        self.total = 0.0
        self.terminated = False  # single-agent mode: the last step's ``terminated``
        self.plan = Stopwatch()
        self._policy = self.plan.timing(policy)
        self._on_reset = on_reset
        self.held_before: list[bool] = []
        self.events = dict.fromkeys((e.name for e in EventType), 0)
        self.actions: list = []

    @property
    def plan_s(self) -> float:
        return sum(self.plan.seconds)

    def started(self, env) -> None:
        """After the reset: the simulator's step count, then the caller's ``on_reset``."""
        self.sim = env.unwrapped.sim
        self.start = self.sim.state.step_count
        if self._on_reset is not None:
            self._on_reset(env)

    def decide(self, observation) -> Any:
        """Who holds a component before the step, then the policy's call, timed."""
        self.held_before = [c != NOBODY for c in self.sim.state.held]
        return self._policy(observation)

    def busy_cranes(self) -> int:
        """The cranes that held a component before the step or hold one after it."""
        held = self.sim.state.held
        return sum(1 for i, before in enumerate(self.held_before) if before or held[i] != NOBODY)

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
            "plan_ms_max": 1000.0 * max(self.plan.seconds, default=0.0),
        }
        if record:
            out["actions"] = self.actions
        return out


def _multi_agent(env, policy, seed, record, on_reset, on_step) -> dict[str, Any]:
    base = env.unwrapped
    agents = env.possible_agents
    first = agents[0]
    tally = _Tally(base, policy, on_reset)

    def stepped(actions, out) -> None:
        _, rewards, _, _, infos = out
        reward = float(rewards[first])
        tally.calls += 1
        tally.steps = tally.sim.state.step_count - tally.start  # simulated steps (task mode)
        tally.total += reward
        if "crane_steps" in infos[first]:
            tally.busy += infos[first]["crane_steps"]
        else:
            tally.busy += tally.busy_cranes()
        for crane_events in base.last_events:
            tally.count(crane_events)
        if record or on_step is not None:
            joint = [int(actions[a]) for a in agents]
            if record:
                tally.actions.append(joint)
            if on_step is not None:
                on_step(env, joint, reward, infos)

    play(env, tally.decide, seed, on_reset=tally.started, after_step=stepped)
    sim = base.sim
    out = tally.result(base.scenario.name, seed, bool(sim.done), record)
    if base.mode.task_level:
        out["decision_rounds"] = tally.calls
        out["plan_ms_per_step"] = 1000.0 * tally.plan_s / tally.calls if tally.calls else 0.0
    return out


def _single_agent(env, policy, seed, record, on_reset, on_step) -> dict[str, Any]:
    base = env.unwrapped
    tally = _Tally(base, policy, on_reset)

    def stepped(action, out) -> None:
        reward = float(out[1])
        tally.steps += 1
        tally.total += reward
        tally.busy += tally.busy_cranes()
        tally.count(base.last_events)
        tally.terminated = bool(out[2])
        if record:
            tally.actions.append(int(action))
        if on_step is not None:
            on_step(env, action, reward, out[4])

    play(env, tally.decide, seed, on_reset=tally.started, after_step=stepped)
    return tally.result(base.scenario.name, seed, tally.terminated, record)


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
