"""The multi-agent environment: a PettingZoo ``ParallelEnv`` over the simulator core."""

from __future__ import annotations

from pathlib import Path
from textwrap import indent
from typing import Any

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv

from multicrane.core.codes import Event, EventType
from multicrane.core.schema import Scenario
from multicrane.envs.boundary import (
    action_index,
    as_integer,
    crane_count,
    handed_out,
    one_of,
    require_reset,
)
from multicrane.envs.decision_modes import DEFAULT_DECISIONS, DecisionMode, decision_mode
from multicrane.envs.infos import TaskStepFacts, crane_infos
from multicrane.envs.motion_mode import ModeSettings, describe_action
from multicrane.render.image import SiteImage
from multicrane.render.text import render_ansi
from multicrane.scenario.loader import load_scenario
from multicrane.sim.events import EventSpec, resolve
from multicrane.sim.simulator import Simulator
from multicrane.sim.transitions import table_text

ENV_VERSION = 1
REWARDS = ("paper", "makespan")
REWARD_MODES = ("team", "split")
OBS_FORMATS = ("dict", "flat")


class MultiCraneEnv(ParallelEnv):
    """Cranes assembling a prefabricated building on a voxel site (PettingZoo parallel API).

    **Agents.** ``crane_0 … crane_{n-1}``, all present for the whole episode. Cranes are
    abstract: they carry components; only components occupy cells and collide.

    **Actions.** ``Discrete(8 + C)`` per crane, C the number of components:
    ``0`` x-1, ``1`` y-1, ``2`` x+1, ``3`` y+1, ``4`` up, ``5`` down (move the held
    component one cell), ``6`` wait, ``7`` assemble the held component once it has arrived,
    ``8 + i`` claim component ``i`` (scenario order). Claiming lifts an initial component to
    its pick-up pose. Each step the cranes act one after another in an order drawn from the
    episode's generator; each action sees the site as the earlier ones left it, so two
    components never share a cell, two claims of one component go to the earlier crane (the
    later one gets a ``CLAIM_CONFLICT`` event) and two moves into one cell go to the earlier.
    An action outside the mask does nothing and is recorded as an event (``BLOCKED`` for a
    move into something, else ``ILLEGAL``); with ``strict=True`` it raises ``ValueError``.

    **Automatic mode** (``auto=True``): the paper's process. Each idle crane is given the next
    component of the scenario's list order, its first move lifts it, and it is assembled on
    arrival; claim and assemble actions are masked out. With one crane this is exactly the
    paper's single-agent process (``docs/paper-spec.md`` section 5).

    **Task level** (``decisions="task"``; default ``"motion"``: everything above). Each crane
    decides which task it does next instead of every move: ``Discrete(1 + P)``, P the
    (component, compatible target) pairs of the scenario numbered component-major
    (``multicrane.tasks.book.TaskList``): ``0`` wait (a busy crane: continue), ``1 + p`` take task
    ``p``. An idle crane's mask allows the tasks whose component is claimable and not another
    crane's, whose target is free, ready and not another crane's, and that the crane can
    carry (reach, a static path); a busy crane's allows only ``0``. The environment's carrier
    (``multicrane.tasks.carrier``) carries the component along a reserved space-time path with the
    ordinary motion actions, and ``step`` advances simulated time until some crane becomes
    idle, an idle crane has an allowed task, or the episode ends (at least one simulated
    step). A task whose path search fails is held and retried each step, and dropped after
    ``task_patience`` (20) steps. The observation is the task tables of
    ``multicrane.envs.task_observation`` (``task_site_planes=True`` adds the site planes).
    ``infos`` add ``elapsed`` (simulated steps), ``task_events`` and ``crane_steps``;
    ``env.task_feasible(crane, p)`` runs the search for a planner. See ``docs/task-mode.md``.
    The levels are the decision modes of ``multicrane.envs.decision_modes`` (one table by
    name): ``env.decisions`` is the name, ``env.mode`` the mode the env delegates to (a
    planner reaches the task book as ``env.mode.task_book()``).

    **Observation.** ``{"observation": float32 vector in [0, 1], "action_mask": int8 vector}``;
    with ``obs_format="flat"`` only the vector (a ``Box``; the mask then comes from
    ``action_masks()`` and, by default in that format, ``infos[agent]["action_mask"]``).
    The vector is the site as (X, Y, 9) height planes, a (C, 14) component table and a 9-value
    crane vector; see ``multicrane.envs.observation`` and ``env.observation_layout.split(obs)``.
    Its shape is fixed for a scenario. The mask always allows ``wait``.

    **Reward.** One team reward, the same for every crane: ``N`` (assembled components, pre-
    built included) for each component assembled this step, ``completion`` (10) on the step
    that finishes the building, otherwise ``-over_limit_cost`` (2) while a crane holds a
    component past ``move_limit`` (15) moves and ``-step_cost / (k + 1)`` else, ``k`` the
    components assembled this episode. For one crane in automatic mode this is exactly the
    paper's reward (``reward="paper"``, the default). ``reward="makespan"``: ``-1`` per
    simulated step for the team, plus ``completion`` on the finishing step (so the return is
    ``completion - makespan``). In task mode the reward of a step is the sum over the
    simulated steps it advanced. ``reward_mode="team"`` (default) gives every crane the team
    reward; ``"split"`` gives each crane its share ``reward_term`` (the shares add up to the
    team reward, so a sum over cranes, as RLlib and SB3's monitors take, is the team return).

    **Infos** (``multicrane.envs.infos``): numbers only, the same keys at reset and every
    step: ``event_counts`` (this crane's events per ``EventType``), ``reward_term`` and, at
    the task level, ``task_event_counts``, ``elapsed`` and ``crane_steps``. ``info_events=True``
    adds the readable ``events`` (``Event`` tuples) and ``task_events``; ``info_mask=True``
    adds ``action_mask``. ``env.last_events`` always holds the last step's events per crane.

    **Global state** (centralised critics): ``state()`` is every crane's observation vector
    concatenated in crane order, ``state_space`` a ``Box(0, 1, (N * D,), float32)``.

    **Termination / truncation.** Terminated when every component is assembled; truncated at
    the step limit (the scenario's, or ``max_steps``) if not terminated. The clock is the
    simulator's step count in both decision levels (step limit, makespan, metrics).
    ``max_cycles`` (PettingZoo's name) also truncates after that many ``step`` calls.

    **Arguments.** ``scenario`` (shipped name like ``"e3s2"``, a path, or a ``Scenario``),
    ``n_cranes`` (default: the scenario's), ``auto`` (False), ``strict`` (False),
    ``max_steps`` (default: the scenario's ``step_limit``), ``max_cycles`` (None),
    ``render_mode`` (None, ``"ansi"``, ``"rgb_array"``: an isometric picture of the site,
    ``multicrane.render.image``, or ``"human"``: the live rerun viewer of
    ``multicrane.render.live``, needs the ``replay`` extra; with no viewer to reach, a one-line
    warning and nothing shown), ``decisions`` (``"motion"`` or
    ``"task"``), ``reward`` (``"paper"`` or ``"makespan"``), ``reward_mode`` (``"team"`` or
    ``"split"``), ``obs_format`` (``"dict"`` or ``"flat"``), ``info_events`` (False),
    ``info_mask`` (default: True for ``"flat"``, else False), ``task_patience`` (20),
    ``task_site_planes`` (False), ``events`` (None: the scenario's ``[events]`` table if any,
    else none; ``"none"``, ``"low"``, ``"high"`` or an ``EventSpec``: late deliveries, crane
    breakdowns and closed zones drawn from the seed given to ``reset``; the observation then
    gains the events block, and ``infos`` ``site_event_counts``; see ``docs/uncertainty.md``).

    **Version history.** v0: first release. v1: numeric infos by default (``info_events``,
    ``info_mask``), task-level decisions, reward options, crane reach, the global ``state()``.

    **Component states** (``multicrane.sim.transitions``; pre-built components start assembled):
    """

    metadata = {
        "name": f"multicrane_v{ENV_VERSION}",
        "render_modes": ["ansi", "rgb_array", "human"],
        "render_fps": 4,
        "is_parallelizable": True,
    }

    def __init__(
        self,
        scenario: str | Path | Scenario = "e2s2",
        n_cranes: int | None = None,
        auto: bool = False,
        strict: bool = False,
        max_steps: int | None = None,
        render_mode: str | None = None,
        decisions: str = DEFAULT_DECISIONS,
        reward: str = "paper",
        task_patience: int = 20,
        task_site_planes: bool = False,
        max_cycles: int | None = None,
        reward_mode: str = "team",
        obs_format: str = "dict",
        info_events: bool = False,
        info_mask: bool | None = None,
        events: EventSpec | str | None = None,
    ):
        one_of("render_mode", render_mode, (None, *self.metadata["render_modes"]))
        one_of("reward_mode", reward_mode, REWARD_MODES)
        one_of("obs_format", obs_format, OBS_FORMATS)
        self.reward_mode = reward_mode
        self.obs_format = obs_format
        self.info_events = bool(info_events)
        self.info_mask = obs_format == "flat" if info_mask is None else bool(info_mask)
        self.max_cycles = as_integer(max_cycles, "max_cycles") if max_cycles is not None else None
        if self.max_cycles is not None and self.max_cycles < 1:
            raise ValueError(f"max_cycles must be at least 1, got {max_cycles!r}")
        mode_class = decision_mode(decisions)
        if reward not in REWARDS:
            raise ValueError(f"reward must be one of {REWARDS}, got {reward!r}")
        self.decisions = decisions
        self.reward = reward
        self.scenario = load_scenario(scenario)
        n_cranes = crane_count(n_cranes)
        limit = as_integer(max_steps, "max_steps") if max_steps is not None else None
        self.step_limit = limit if limit is not None else self.scenario.step_limit
        spec = resolve(events, self.scenario)
        self.sim = Simulator(self.scenario, n_cranes, auto, spec, self.step_limit)
        settings = ModeSettings(reward, self.step_limit, task_patience, task_site_planes)
        self.mode: DecisionMode = mode_class(self.sim, settings)
        self.observer = self.mode.observer
        self.observation_layout = self.observer.layout
        self.auto = auto
        self.strict = strict
        self.render_mode = render_mode
        if self.step_limit < 1:
            raise ValueError(f"max_steps must be at least 1, got {max_steps!r}")
        n = self.sim.n_cranes
        self.possible_agents = [f"crane_{i}" for i in range(n)]
        self.agents: list[str] = []
        self.n_actions = n_actions = self.mode.n_actions
        self._action_space = spaces.Discrete(n_actions)
        vector = spaces.Box(0.0, 1.0, (self.observer.layout.size,), np.float32)
        self._observation_space = (
            vector
            if obs_format == "flat"
            else spaces.Dict(
                {"observation": vector, "action_mask": spaces.Box(0, 1, (n_actions,), np.int8)}
            )
        )
        self.state_space = spaces.Box(0.0, 1.0, (n * self.observer.layout.size,), np.float32)
        self._state = np.zeros(self.state_space.shape, dtype=np.float32)
        self._state_due = False  # state() must first build _state from the observer
        self.last_events: list[tuple[Event, ...]] = [() for _ in range(n)]
        self.last_site_events: tuple = ()  # the schedule's events of the last step or reset
        self.cycles = 0
        self._human = None
        self._image: SiteImage | None = None
        self._rng: np.random.Generator | None = None
        self._masks: list[np.ndarray] = []  # the env's own; callers get copies (_shown)
        self._observed = True  # False after ``advance``: masks and state not built yet
        self._shown: list[np.ndarray] = []

    # -- spaces ------------------------------------------------------------------------------

    def observation_space(self, agent: str) -> spaces.Dict | spaces.Box:
        return self._observation_space

    def action_space(self, agent: str) -> spaces.Discrete:
        return self._action_space

    # -- episode -----------------------------------------------------------------------------

    @property
    def np_random(self) -> np.random.Generator:
        """The episode's generator (PettingZoo's ``np_random``; reseeded by ``reset(seed)``)."""
        if self._rng is None:
            self._rng = np.random.default_rng()
        return self._rng

    def reset(self, seed: int | None = None, options: dict | None = None):
        if seed is not None or self._rng is None:
            self._rng = np.random.default_rng(seed)
        self.cycles = 0
        self.sim.reset(self._rng, schedule=(options or {}).get("schedule"))
        self.agents = list(self.possible_agents)
        self.total_reward = 0.0
        facts = self.mode.reset(self._rng)
        observations = self._observe()
        n = self.sim.n_cranes
        self.last_events = [() for _ in range(n)]
        self.last_site_events = tuple(self.sim.site_log)
        infos = self._infos([0.0] * n, facts)
        if self.render_mode == "human":
            self._human_view().reset(self)
        return observations, infos

    def step(self, actions: dict[str, Any]):
        r, terms, facts, complete, truncated = self._play(actions, "step")
        observations = self._observe()
        agents = self.possible_agents
        if self.reward_mode == "team":
            rewards = dict.fromkeys(agents, r)
        else:
            rewards = {a: float(terms[i]) for i, a in enumerate(agents)}
        terminations = dict.fromkeys(agents, complete)
        truncations = dict.fromkeys(agents, truncated)
        infos = self._infos(terms, facts)
        if complete or truncated:
            self.agents = []
        if self.render_mode == "human":
            self._human_view().step(self, r)
        return observations, rewards, terminations, truncations, infos

    def advance(self, actions: dict[str, Any]) -> tuple[bool, bool]:
        """``step`` for rollouts on copies by rules that read no observations: it builds none
        (nor the masks and state, until asked for) and returns ``(terminated, truncated)``."""
        _, _, _, complete, truncated = self._play(actions, "advance")
        self._observed = False
        if complete or truncated:
            self.agents = []
        return complete, truncated

    def _play(self, actions: dict[str, Any], what: str):
        """``step``'s move: (reward, terms, task facts, complete, truncated)."""
        if not self.agents:
            raise RuntimeError(f"{what}() called on a finished episode: call reset() first")
        joint = self._joint_action(actions)
        mark = len(self.sim.site_log)
        r, terms, per_crane, facts = self.mode.step(joint)
        self.cycles += 1
        self.last_events = per_crane
        self.last_site_events = tuple(self.sim.site_log[mark:])
        complete = self.sim.done
        self.total_reward += r
        truncated = not complete and (
            self.sim.state.step_count >= self.step_limit
            or (self.max_cycles is not None and self.cycles >= self.max_cycles)
        )
        return r, terms, facts, complete, truncated

    def _infos(self, terms, facts: TaskStepFacts | None) -> dict[str, dict[str, Any]]:
        return crane_infos(
            self.possible_agents,
            self.last_events,
            terms,
            self._shown,
            events=self.info_events,
            mask=self.info_mask,
            task=facts,
            site=self.last_site_events if self.sim.events is not None else None,
        )

    def _joint_action(self, actions: dict[str, Any]) -> list[int]:
        if self.strict and not self._observed:
            self._observe()  # the masks after an ``advance``
        joint = []
        for i, agent in enumerate(self.possible_agents):
            if agent not in actions:
                raise KeyError(f"step(): no action for {agent!r}; every crane acts every step")
            a = action_index(actions[agent], agent, self.n_actions)
            if self.strict and not self._masks[i][a]:
                what = self.mode.describe(a)
                raise ValueError(f"step(): {agent} sent illegal action {a} ({what})")
            joint.append(a)
        return joint

    def _observe(self) -> dict[str, Any]:
        obs, masks = self.mode.observe()
        self._observed = True
        self._masks = masks
        # The global state is built when asked for, by the observer, which rebuilds the rows
        # it last returned (the caller may have changed them).
        self._state_due = True
        self._shown = handed_out(self._masks)
        if self.obs_format == "flat":
            return dict(zip(self.possible_agents, obs, strict=True))
        return {
            a: {"observation": obs[i], "action_mask": self._shown[i]}
            for i, a in enumerate(self.possible_agents)
        }

    # -- extras --------------------------------------------------------------------------------

    @property
    def wait_action(self) -> int:
        """The action that waits: ``0`` in task mode, ``WAIT`` (6) at the motion level."""
        return self.mode.wait_action

    def task_feasible(self, crane: int, task: int) -> bool:
        """Task mode: would ``task`` start for ``crane`` now (the carrier's space-time search
        succeeds)? The plan found is kept and used if the crane chooses the task in the next
        ``step`` (see ``multicrane.tasks.book.TaskBook.feasible``)."""
        return self.mode.feasible(int(crane), int(task))

    def action_masks(self) -> dict[str, np.ndarray]:
        """The current legal-action mask of every crane (copies)."""
        require_reset(bool(self._masks), "action_masks")
        if not self._observed:
            self._observe()
        return {a: m.copy() for a, m in zip(self.possible_agents, self._masks, strict=True)}

    def state(self) -> np.ndarray:
        """The global state (``state_space``): every crane's observation vector, concatenated
        in crane order; it holds the site planes, the component table and every crane's own
        features, for a centralised critic."""
        require_reset(bool(self._masks), "state")
        if not self._observed:
            self._observe()
        if self._state_due:
            self.observer.last_rows(out=self._state.reshape(len(self.possible_agents), -1))
            self._state_due = False
        return self._state.copy()

    def render(self) -> str | np.ndarray | None:
        require_reset(bool(self._masks), "render")
        if self.render_mode == "ansi":
            return render_ansi(self.sim)
        if self.render_mode == "rgb_array":
            if self._image is None:
                self._image = SiteImage(self.sim)
            return self._image.draw(self.sim)
        return None  # "human": every reset and step is already streamed to the viewer

    def _human_view(self):
        if self._human is None:
            from multicrane.render.live import LiveView

            self._human = LiveView()
        return self._human

    def close(self) -> None:
        if self._human is not None:
            self._human.close()
            self._human = None


MultiCraneEnv.__doc__ += "\n" + indent(table_text(), "    ") + "\n"


__all__ = ["MultiCraneEnv", "EventType", "describe_action"]
