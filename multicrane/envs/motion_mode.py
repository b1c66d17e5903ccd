"""The motion decision mode: one move per crane per step, and the physical step every mode uses.

``MotionMode`` is the default mode of ``MultiCraneEnv`` (``decisions="motion"``): each crane
sends one of the ``Discrete(8 + C)`` motion actions (``describe_action`` names them), the
masks are the simulator's, the observation is ``multicrane.envs.observation``'s and one env
step is one simulated step (``physical_step``: the crane order drawn from the episode's
generator, the reward of ``multicrane.envs.reward``). It asks for no tasks, so the planner
methods of the task level (``feasible``, ``task_book``, ``carrier_stats``) refuse.
``ModeSettings`` are the environment options a mode is built with, ``ModeStep`` what a
mode's step hands back to the environment.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from multicrane.core.codes import CLAIM_BASE, WAIT, Event, Status
from multicrane.envs import reward as reward_rules
from multicrane.envs.infos import TaskStepFacts
from multicrane.envs.observation import Observer
from multicrane.sim.simulator import NOBODY, Simulator, StepOutcome

_INITIAL = int(Status.INITIAL)
_MOTION_NAMES = ("x-1", "y-1", "x+1", "y+1", "up", "down", "wait", "assemble")


@dataclass(frozen=True)
class ModeSettings:
    """The options of ``MultiCraneEnv`` a decision mode is built with."""

    reward: str  # "paper" or "makespan"
    step_limit: int
    task_patience: int = 20
    task_site_planes: bool = False


class ModeStep(NamedTuple):
    """One env step of a mode: the team reward, the per-crane reward terms, each crane's
    physical events, and the task facts for the infos (None below the task level)."""

    reward: float
    terms: list[float]
    events: list[tuple[Event, ...]]
    facts: TaskStepFacts | None


def physical_step(sim: Simulator, rng: np.random.Generator, reward: str, joint: list[int]):
    """One simulated step with one motion action per crane (the crane order drawn from
    ``rng``): ``(outcome, reward, reward terms, paper reward)``."""
    n = sim.n_cranes
    order = None
    if n > 1:  # ``rng.permutation(n).tolist()``: the same draws, shuffled in a list (faster)
        order = list(range(n))
        rng.shuffle(order)
    out: StepOutcome = sim.step(joint, order)
    paper, progress_by, over = reward_rules.step_reward(sim, out)
    if reward == "paper":
        return out, paper, reward_rules.split(paper, n, progress_by, over), paper
    r = reward_rules.makespan_reward(sim.scenario.reward, sim.done)
    return out, r, [r / n] * n, paper


def describe_action(action: int) -> str:
    """The readable name of a motion action (``"x-1"`` .. ``"claim component i"``)."""
    if action < CLAIM_BASE:
        return _MOTION_NAMES[action]
    return f"claim component {action - CLAIM_BASE}"


def _no_tasks(what: str) -> ValueError:
    return ValueError(f"{what} needs task-level decisions: MultiCraneEnv(decisions='task')")


class MotionMode:
    """Every move decided by the cranes (see the module doc); a ``DecisionMode``."""

    task_level = False
    wait_action = WAIT

    def __init__(self, sim: Simulator, settings: ModeSettings):
        self.sim = sim
        self.settings = settings
        self.observer = Observer(sim)
        self.n_actions = sim.site.n_actions
        self.rng: np.random.Generator | None = None

    def reset(self, rng: np.random.Generator) -> TaskStepFacts | None:
        """Start an episode (the simulator is already reset) drawing from ``rng``; returns
        what the reset's infos add (nothing here)."""
        self.rng = rng
        self.observer.reset(self.settings.step_limit)
        return None

    def step(self, joint: list[int]) -> ModeStep:
        out, r, terms, _ = physical_step(self.sim, self.rng, self.settings.reward, joint)
        per_crane: list[list[Event]] = [[] for _ in range(self.sim.n_cranes)]
        for e in out.events:
            per_crane[e.crane].append(e)
        return ModeStep(r, terms, [tuple(x) for x in per_crane], None)

    def observe(self) -> tuple[np.ndarray, list[np.ndarray]]:
        """Every crane's observation vector (rows) and action mask, in crane order."""
        sim = self.sim
        if sim.auto:
            status = sim.state.status
            ready = [c for c in sim.state.held if c != NOBODY and status[c] == _INITIAL]
        else:
            ready = sim.claimable_components()
        self.observer.update(sim.take_changed(), ready)
        masks = list(sim.action_masks())
        return self.observer.observe_all(), masks

    def describe(self, action: int) -> str:
        return describe_action(action)

    # -- what a planner may ask (the task level's; refused here) -------------------------------

    def feasible(self, crane: int, task: int) -> bool:
        raise RuntimeError("task_feasible() needs decisions='task'")

    def task_book(self):
        raise _no_tasks("the task book")

    def carrier_stats(self) -> dict:
        raise _no_tasks("the carrier's statistics")
