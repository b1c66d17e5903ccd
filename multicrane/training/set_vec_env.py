"""The vector environment of the set policy: task-mode copies of any sites, padded rows.

``SetVecEnv`` is ``CraneVecEnv`` (one SB3 row per (copy, crane), the copies' own seeds,
truncation, masks, shaping, team-return episode statistics) for task-level environments whose
sites may differ in size: every observation is padded to ``SetLimits``
(``multicrane.training.set_obs``) and every copy has ``limits.cranes`` rows. A copy whose
site has fewer cranes fills its spare rows with a constant dummy observation that may only
wait, gets reward 0 and ends every step (so it adds nothing to the policy gradient and its
value target is 0). ``reward_scale="site"`` divides each copy's environment reward by its
site's static work per crane (``site_work``), so that sites of every size weigh alike in the
learner's returns; episode statistics stay in the environment's reward. With a ``sites``
source (``multicrane.training.curriculum``), a copy may move to another site at each
episode's reset; every reset then takes an explicit seed from the copy's generator, so a
resumed run replays the same episodes.
"""

from __future__ import annotations

import pickle
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from gymnasium import spaces

from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.training.config import REWARD_SCALES
from multicrane.training.set_obs import HEADER, Padder, SetLimits
from multicrane.training.shaping import DistancePotential
from multicrane.training.vec_env import CraneVecEnv


def site_work(env: MultiCraneEnv) -> float:
    """A task-mode site's static work per crane, after a reset: the sum over components of
    the shortest static path length of any of its tasks by any crane, over the cranes (at
    least 1). On 40 ``train`` sites of 1-32 components it tracks the prioritized planner's
    makespan (correlation of the logarithms 0.96; makespan / work 1.08-1.99, median 1.35)."""
    book = env.mode.task_book()
    none = np.iinfo(np.int64).max  # no crane reaches it
    lengths = np.where(book.static_ok, book.static_len, none).min(axis=0)
    per_component = np.full(env.sim.site.n_components, none)
    np.minimum.at(per_component, book.tasks.comp, lengths)
    reachable = per_component[per_component < none]
    return max(1.0, float(reachable.sum()) / len(env.possible_agents))


def dummy_observation(limits: SetLimits) -> np.ndarray:
    """The spare rows' observation: one zero component and one zero crane, no task."""
    out = np.zeros(limits.size, dtype=np.float32)
    out[:HEADER] = (1, 1, 0)
    return out


class SetVecEnv(CraneVecEnv):
    """``n_envs`` task-mode copies (``make_env(copy)``), ``limits.cranes`` rows per copy.

    ``sites``: optional source of sites with ``next_env(copy, rng) -> MultiCraneEnv | None``
    (None keeps the copy's site) and ``record(copy, episode_info)``; the source is part of
    the checkpointed state."""

    def __init__(
        self,
        make_env: Callable[[int], MultiCraneEnv],
        n_envs: int,
        limits: SetLimits,
        shaping: float = 0.0,
        gamma: float = 0.99,
        sites=None,
        reward_scale: str = "none",
    ):
        if n_envs < 1:
            raise ValueError(f"n_envs must be at least 1, got {n_envs}")
        if reward_scale not in REWARD_SCALES:
            raise ValueError(f"reward_scale={reward_scale!r}: one of {', '.join(REWARD_SCALES)}")
        self.reward_scale = reward_scale
        self._scales = np.ones(n_envs)
        if shaping < 0:
            raise ValueError(f"shaping must be >= 0, got {shaping}")
        self.limits = limits
        self.sites = sites
        self.envs = [make_env(i) for i in range(n_envs)]
        self._padders = [self._padder(env, i) for i, env in enumerate(self.envs)]
        self.shaping, self.gamma = float(shaping), float(gamma)
        self._potentials = np.zeros(n_envs)
        self._phi: list[DistancePotential | None] = [None] * n_envs
        self.n_agents = limits.cranes  # rows per copy
        self.n_copies = n_envs
        self.agents = [f"row_{j}" for j in range(limits.cranes)]
        space = spaces.Box(0.0, np.float32(max(limits.to_dict().values())), (limits.size,),
                           dtype=np.float32)  # fmt: skip
        super(CraneVecEnv, self).__init__(
            n_envs * limits.cranes, space, spaces.Discrete(limits.n_actions)
        )
        self._dummy = dummy_observation(limits)
        self._copy_seeds: list[int | None] = [None] * n_envs
        self._rngs: list[np.random.Generator | None] = [None] * n_envs
        self._obs = np.zeros((self.num_envs, limits.size), dtype=np.float32)
        self._masks = np.zeros((self.num_envs, limits.n_actions), dtype=bool)
        self._returns = np.zeros(n_envs)
        self._lengths = np.zeros(n_envs, dtype=np.int64)
        self._starts = [time.perf_counter()] * n_envs
        self._actions: np.ndarray | None = None

    def _padder(self, env: MultiCraneEnv, copy: int) -> Padder:
        if not env.mode.task_level:
            raise ValueError(f"copy {copy}: the set policy needs decisions='task'")
        self.limits.check(env.observation_layout, f"copy {copy} ({env.scenario.name})")
        return Padder(env.observation_layout, self.limits, env)

    # -- stepping ----------------------------------------------------------------------------

    def _store(self, copy: int, observations: dict) -> None:
        env, pad = self.envs[copy], self._padders[copy]
        base = copy * self.n_agents
        masks = env.action_masks()
        agents = env.possible_agents
        proposed = pad.proposals()
        for j, agent in enumerate(agents):
            o = observations[agent]
            o = o["observation"] if isinstance(o, dict) else o
            pad.pad(o, self._obs[base + j], proposed[j])
            pad.pad_mask(masks[agent], self._masks[base + j])
        for j in range(len(agents), self.n_agents):
            self._obs[base + j] = self._dummy
            self._masks[base + j] = False
            self._masks[base + j, 0] = True

    def _potential(self, copy: int) -> float:
        if self._phi[copy] is None or self._phi[copy].sim is not self.envs[copy].sim:
            self._phi[copy] = DistancePotential(self.envs[copy].sim)
        return self._phi[copy]()

    def _reset_copy(self, copy: int) -> None:
        seed = self._copy_seeds[copy]
        if seed is not None:  # the first reset after seed(): the copy's generator starts
            self._rngs[copy] = np.random.default_rng(seed)
        rng = self._rngs[copy]
        if rng is None:
            self._rngs[copy] = rng = np.random.default_rng()
        if self.sites is not None:
            env = self.sites.next_env(copy, rng)
            if env is not None and env is not self.envs[copy]:
                self._padders[copy] = self._padder(env, copy)
                self.envs[copy] = env
        observations, _ = self.envs[copy].reset(seed=int(rng.integers(2**31)))
        self._copy_seeds[copy] = None
        self._start_episode(copy, observations)

    def _start_episode(self, copy: int, observations: dict) -> None:
        if self.reward_scale == "site":
            self._scales[copy] = site_work(self.envs[copy])
        super()._start_episode(copy, observations)

    def step_wait(self):
        rows = self.n_agents
        rewards = np.zeros(self.num_envs, dtype=np.float32)
        dones = np.zeros(self.num_envs, dtype=bool)
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        actions = self._actions.tolist()
        for copy, env in enumerate(self.envs):
            base = copy * rows
            agents = env.possible_agents
            n = len(agents)
            joint = {agent: actions[base + j] for j, agent in enumerate(agents)}
            observations, team_rewards, terminations, truncations, _ = env.step(joint)
            first = agents[0]
            r = team_rewards[first]
            self._returns[copy] += r
            r = r / self._scales[copy]
            if self.shaping:
                phi = 0.0 if terminations[first] else self._potential(copy)
                r = r + self.shaping * (self.gamma * phi - self._potentials[copy])
                self._potentials[copy] = phi
            rewards[base : base + n] = r
            dones[base + n : base + rows] = True  # spare rows: one-step episodes, reward 0
            self._lengths[copy] = env.sim.state.step_count
            self._store(copy, observations)
            if terminations[first] or truncations[first]:
                success = bool(terminations[first])
                episode = self._end_episode(copy, base, n, success, infos, dones)
                if self.sites is not None:
                    self.sites.record(copy, {**episode, "success": success})
                self._reset_copy(copy)
        return self._obs.copy(), rewards, dones, infos

    # -- attributes --------------------------------------------------------------------------

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs):
        """Like ``CraneVecEnv.env_method``; a spare row's per-crane answer is None."""
        if method_name == "action_masks":
            return list(self._masks[self._rows(indices)])
        out = []
        for r in self._rows(indices):
            env = self.envs[r // self.n_agents]
            value = getattr(env, method_name)(*method_args, **method_kwargs)
            if isinstance(value, dict) and set(value) == set(env.possible_agents):
                j = r % self.n_agents
                value = value[env.possible_agents[j]] if j < len(env.possible_agents) else None
            out.append(value)
        return out

    # -- checkpoints -------------------------------------------------------------------------

    _STATE = (
        "envs", "_copy_seeds", "_rngs", "_obs", "_masks", "_returns", "_lengths",
        "_potentials", "sites", "_scales",
    )  # fmt: skip

    def get_state(self) -> bytes:
        return pickle.dumps({name: getattr(self, name) for name in self._STATE})

    def set_state(self, state: bytes) -> None:
        for name, value in pickle.loads(state).items():
            setattr(self, name, value)
        self._padders = [self._padder(env, i) for i, env in enumerate(self.envs)]
        self._phi = [None] * self.n_copies
        self._starts = [time.perf_counter()] * self.n_copies
