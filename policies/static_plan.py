"""The static baseline: one plan made at reset for the undisturbed site, then executed in order.

``StaticPlan`` is what a site without real-time decisions does: at the first call of an
episode it plans the whole episode with the prioritized planner (``policies.prioritized``) on
a copy of the site *as if undisturbed* (the same start poses, every component on site, every
crane up, no zone closed) and keeps the joint motion actions of every step and the state
before each. Then it executes that plan step by step, on one clock for the whole site:

- the plan's step ``tau`` is sent when the site matches the plan's state before it (every
  component in its planned cells and status, or already assembled where the plan only has it
  arrived; no crane behind the plan in an assembly) and every crane's planned action is
  allowed by its mask;
- otherwise (a component not delivered yet, a crane down, a closed cell, an occupied cell,
  an assembly paused by a breakdown) every crane waits and the clock stands still.

Why one clock: the plan's paths were reserved against each other in time (the reservation
table), so executing them together from the planned state can never collide; letting one
crane run ahead of the others could (two delayed paths may cross in the other order and wait
on each other for ever). While the clock stands the site only moves forward (assemblies
finish, deliveries arrive), and events are finite intervals, so the clock resumes once they
end: the episode finishes exactly as the undisturbed plan, shifted by the waits.

**Never stuck for ever.** If the clock has stood still ``patience`` steps while nothing
disturbs the site (every crane up, no zone closed, everything delivered) the state is one the
plan cannot continue from (which the argument above excludes, so this is a safety net): the
rest of the episode is played by the replanning prioritized planner, and
``stats["fallback"]`` is 1. The same happens if the plan ends before the building does.
``stats`` also counts ``waits`` (steps with the clock standing) and ``plan_steps``.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from multicrane.core.codes import WAIT, Status
from multicrane.envs.decision_modes import task_level
from multicrane.sim.event_knowledge import event_view
from multicrane.sim.simulator import Simulator
from policies.prioritized import PrioritizedPlanner

_ARRIVED, _ASSEMBLED = int(Status.ARRIVED), int(Status.ASSEMBLED)


class _PlannedState:
    """The planned site before one step: statuses, cells and assembly counters."""

    __slots__ = ("status", "cells", "assembling")

    def __init__(self, sim: Simulator):
        st = sim.state
        self.status = st.status.copy()
        self.cells = [tuple(c) for c in st.cells]
        self.assembling = np.array(st.assembling, dtype=np.int64)


def undisturbed_plan(env, max_steps: int, **options) -> tuple[list[list[int]], list]:
    """The prioritized planner's episode on ``env``'s site as if undisturbed: the joint
    actions of every step and the planned state before each (from ``env.sim.start``)."""
    sim = Simulator(env.scenario, env.sim.n_cranes)
    sim.reset(np.random.default_rng(0), start=env.sim.start)
    agents = list(env.possible_agents)
    shadow = SimpleNamespace(sim=sim, scenario=env.scenario, possible_agents=agents)
    planner = PrioritizedPlanner(shadow, **options)
    n_comp = sim.site.n_components
    actions: list[list[int]] = []
    states: list[_PlannedState] = []
    while sim.state.n_assembled < n_comp and sim.state.step_count < max_steps:
        states.append(_PlannedState(sim))
        joint = planner(None)
        actions.append([int(joint[a]) for a in agents])
        sim.step(actions[-1])
    return actions, states


class StaticPlan:
    """Plan once at reset for the undisturbed site, then execute in order (see the module
    doc). ``patience``: steps the clock may stand still on an undisturbed site before the
    replanning planner takes over; ``options`` go to the prioritized planner."""

    def __init__(self, env, seed=None, patience: int = 30, **options):
        if env.sim.auto:
            raise ValueError("StaticPlan drives the default (claiming) mode, not auto=True")
        if task_level(env):
            raise ValueError("static-plan drives motion decisions (decisions='motion')")
        self.env = env
        self.seed = seed
        self.patience = int(patience)
        self.options = options
        self.stats: dict[str, int] = {}
        self._episode: tuple[int, int] | None = None

    def _start(self) -> None:
        sim = self.env.sim
        limit = int(getattr(self.env, "step_limit", sim.scenario.step_limit))
        self.actions, self.states = undisturbed_plan(self.env, limit, **self.options)
        self.tau = 0
        self.stood = 0
        self.fallback: PrioritizedPlanner | None = None
        self.stats = {"plan_steps": len(self.actions), "waits": 0, "fallback": 0}
        view = event_view(sim)
        self._late = sorted(view.undelivered) if view is not None else []
        self._episode = (id(sim.state), id(sim.start))

    def _matches(self, planned: _PlannedState) -> bool:
        """The site is in the plan's state before step ``tau`` (or ahead in assemblies)."""
        sim = self.env.sim
        st = sim.state
        status = st.status
        if self._late:
            self._late = [c for c in self._late if not sim.delivered(c)]
            if self._late:
                return False  # the plan has them on site from the start
        for comp, cells in enumerate(planned.cells):
            s, p = status[comp], planned.status[comp]
            if s != p and not (p == _ARRIVED and s == _ASSEMBLED):
                return False
            if tuple(st.cells[comp]) != cells:
                return False
        return all(st.assembling[k] <= left for k, left in enumerate(planned.assembling))

    def __call__(self, observations: dict) -> dict:
        env, sim = self.env, self.env.sim
        agents = env.possible_agents
        if sim.state.step_count == 0 or self._episode != (id(sim.state), id(sim.start)):
            self._start()
        if self.fallback is not None:
            return self.fallback(observations)
        joint = None
        if self.tau < len(self.actions) and self._matches(self.states[self.tau]):
            planned = self.actions[self.tau]
            masks = [observations[a]["action_mask"] for a in agents] if observations else None
            if masks is None or all(masks[k][a] for k, a in enumerate(planned)):
                joint = planned
        if joint is not None:
            self.tau += 1
            self.stood = 0
            return dict(zip(agents, joint, strict=True))
        self.stats["waits"] += 1
        self.stood += 1
        view = event_view(sim)
        quiet = view is None or view.quiet
        if self.tau >= len(self.actions) or (quiet and self.stood >= self.patience):
            self.stats["fallback"] = 1
            self.fallback = PrioritizedPlanner(env, **self.options)
            return self.fallback(observations)
        return dict.fromkeys(agents, WAIT)


__all__ = ["StaticPlan", "undisturbed_plan"]
