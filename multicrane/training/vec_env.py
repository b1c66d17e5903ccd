"""Vector environments for stable-baselines3.

``CraneVecEnv`` runs ``n_envs`` copies of a ``MultiCraneEnv`` and gives SB3 one row per
(copy, crane): parameter sharing, with one policy acting for every crane. It covers what
SuperSuit's ``pettingzoo_env_to_vec_env_v1`` + ``concat_vec_envs_v1`` recipe lacks (see
``docs/training.md``): each copy gets its own reset seed from the run seed; a time-limit end
is reported as truncation (``TimeLimit.truncated``) so PPO bootstraps it; ``action_masks()``
reaches MaskablePPO; and ``info["episode"]`` feeds SB3's episode statistics. With
``shaping > 0`` the learner's reward gets the potential-based term of
``multicrane.training.shaping`` (returns and statistics stay the environment's).

With a task-level environment (``decisions="task"``) a row is a crane's task choice; a busy
crane's row has the mask ``[1, 0, ...]`` (only "continue"), and episode lengths count
simulated steps. ``SeededDummyVecEnv`` is SB3's ``DummyVecEnv`` with the same seed
derivation, for the single-agent benchmark mode.
"""

from __future__ import annotations

import pickle
import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import DummyVecEnv, VecEnv

from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.training.seeding import copy_seeds
from multicrane.training.shaping import DistancePotential


class CraneVecEnv(VecEnv):
    """``n_envs`` copies of ``make_env()``, one SB3 row per (copy, crane), copy-major.

    Row ``r`` is crane ``r % n_cranes`` of copy ``r // n_cranes``. Every row of a copy gets
    the copy's team reward. Observations are the environment's ``"observation"`` vector;
    masks come from ``action_masks()`` (one bool row per SB3 row). When a copy's episode ends,
    each of its rows reports ``done`` with ``terminal_observation``, ``TimeLimit.truncated``
    and ``episode`` (team return, length, seconds) in its info, and the copy is reset from its
    own generator (seeded once, at the first reset after ``seed()``).
    """

    def __init__(
        self,
        make_env: Callable[[], MultiCraneEnv],
        n_envs: int,
        shaping: float = 0.0,
        gamma: float = 0.99,
    ):
        if n_envs < 1:
            raise ValueError(f"n_envs must be at least 1, got {n_envs}")
        if shaping < 0:
            raise ValueError(f"shaping must be >= 0, got {shaping}")
        self.envs = [make_env() for _ in range(n_envs)]
        self.shaping = float(shaping)
        self.gamma = float(gamma)
        self._potentials = np.zeros(n_envs)
        self._phi: list[DistancePotential] = []
        first = self.envs[0]
        self.agents = list(first.possible_agents)
        self.n_agents = len(self.agents)
        self.n_copies = n_envs
        space = first.observation_space(self.agents[0])
        obs_space = space["observation"] if isinstance(space, spaces.Dict) else space
        super().__init__(n_envs * self.n_agents, obs_space, first.action_space(self.agents[0]))
        self._copy_seeds: list[int | None] = [None] * n_envs
        self._obs = np.zeros((self.num_envs, *obs_space.shape), dtype=obs_space.dtype)
        self._masks = np.ones((self.num_envs, self.action_space.n), dtype=bool)
        self._returns = np.zeros(n_envs)
        self._lengths = np.zeros(n_envs, dtype=np.int64)
        self._starts = [time.perf_counter()] * n_envs
        self._actions: np.ndarray | None = None

    # -- seeding -----------------------------------------------------------------------------

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        """Seeds the copies for their next reset; see ``multicrane.training.seeding``."""
        self._copy_seeds = copy_seeds(seed, self.n_copies)
        return list(self._copy_seeds)

    # -- stepping ----------------------------------------------------------------------------

    def _store(self, copy: int, observations: dict) -> None:
        env = self.envs[copy]
        base = copy * self.n_agents
        masks = env.action_masks()
        for j, agent in enumerate(self.agents):
            o = observations[agent]
            self._obs[base + j] = o["observation"] if isinstance(o, dict) else o
            self._masks[base + j] = masks[agent]

    def _potential(self, copy: int) -> float:
        if not self.shaping:
            return 0.0
        if len(self._phi) != self.n_copies:
            self._phi = [DistancePotential(env.sim) for env in self.envs]
        return self._phi[copy]()

    def _reset_copy(self, copy: int) -> None:
        observations, _ = self.envs[copy].reset(seed=self._copy_seeds[copy])
        self._copy_seeds[copy] = None
        self._start_episode(copy, observations)

    def _start_episode(self, copy: int, observations: dict) -> None:
        """Zero the copy's episode counters and potential after its reset; store its rows."""
        if self.shaping:
            self._potential(copy)  # builds the potentials on first use
            self._phi[copy].reset()
            self._potentials[copy] = self._potential(copy)
        self._returns[copy] = 0.0
        self._lengths[copy] = 0
        self._starts[copy] = time.perf_counter()
        self._store(copy, observations)

    def reset(self):
        for copy in range(self.n_copies):
            self._reset_copy(copy)
        return self._obs.copy()

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions).reshape(self.num_envs)

    def step_wait(self):
        n = self.n_agents
        rewards = np.zeros(self.num_envs, dtype=np.float32)
        dones = np.zeros(self.num_envs, dtype=bool)
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        actions = self._actions.tolist()
        for copy, env in enumerate(self.envs):
            base = copy * n
            joint = {agent: actions[base + j] for j, agent in enumerate(self.agents)}
            observations, team_rewards, terminations, truncations, _ = env.step(joint)
            first = self.agents[0]
            r = team_rewards[first]
            self._returns[copy] += r
            if self.shaping:
                phi = 0.0 if terminations[first] else self._potential(copy)
                shaped = r + self.shaping * (self.gamma * phi - self._potentials[copy])
                self._potentials[copy] = phi
                rewards[base : base + n] = shaped
            else:
                rewards[base : base + n] = r
            self._lengths[copy] = env.sim.state.step_count  # simulated steps (task mode)
            self._store(copy, observations)
            if terminations[first] or truncations[first]:
                self._end_episode(copy, base, n, bool(terminations[first]), infos, dones)
                self._reset_copy(copy)
        return self._obs.copy(), rewards, dones, infos

    def _end_episode(self, copy: int, base: int, n: int, success: bool, infos: list,
                     dones: np.ndarray) -> dict[str, Any]:  # fmt: skip
        """Mark the copy's ``n`` crane rows done, with SB3's end-of-episode infos (the
        terminal observation, time-limit flag, Monitor-style episode and success); the
        episode summary."""
        episode = {
            "r": float(self._returns[copy]),
            "l": int(self._lengths[copy]),
            "t": round(time.perf_counter() - self._starts[copy], 6),
        }
        for j in range(n):
            infos[base + j] = {
                "terminal_observation": self._obs[base + j].copy(),
                "TimeLimit.truncated": not success,
                "episode": episode,
                "is_success": success,
            }
        dones[base : base + n] = True
        return episode

    # -- masks and attributes ----------------------------------------------------------------

    def action_masks(self) -> np.ndarray:
        """The legal actions of every row (``num_envs`` x ``n_actions`` bools)."""
        return self._masks.copy()

    def _rows(self, indices) -> list[int]:
        if indices is None:
            return list(range(self.num_envs))
        if isinstance(indices, int):
            return [indices]
        return list(indices)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs):
        """Calls the method on each row's copy; a per-crane dict answer (like
        ``action_masks()``) is narrowed to the row's crane."""
        if method_name == "action_masks":
            return list(self._masks[self._rows(indices)])
        out = []
        for r in self._rows(indices):
            value = getattr(self.envs[r // self.n_agents], method_name)(
                *method_args, **method_kwargs
            )
            if isinstance(value, dict) and self.agents[r % self.n_agents] in value:
                value = value[self.agents[r % self.n_agents]]
            out.append(value)
        return out

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        if attr_name == "action_masks":
            return [self.action_masks for _ in self._rows(indices)]
        return [getattr(self.envs[r // self.n_agents], attr_name) for r in self._rows(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        for copy in sorted({r // self.n_agents for r in self._rows(indices)}):
            setattr(self.envs[copy], attr_name, value)

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        return [False for _ in self._rows(indices)]

    def close(self) -> None:
        for env in self.envs:
            env.close()

    # -- checkpoints -------------------------------------------------------------------------

    _STATE = ("envs", "_copy_seeds", "_obs", "_masks", "_returns", "_lengths", "_potentials")

    def get_state(self) -> bytes:
        """Everything needed to continue exactly from here (copies, buffers, counters)."""
        return pickle.dumps({name: getattr(self, name) for name in self._STATE})

    def set_state(self, state: bytes) -> None:
        for name, value in pickle.loads(state).items():
            setattr(self, name, value)
        self._phi = []  # rebuilt on the restored simulators
        self._starts = [time.perf_counter()] * self.n_copies


class SeededDummyVecEnv(DummyVecEnv):
    """SB3's ``DummyVecEnv``; ``seed()`` derives independent per-copy seeds, and the copies'
    state can be saved and restored for an exact resume."""

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        self._seeds = copy_seeds(seed, self.num_envs)
        return list(self._seeds)

    def action_masks(self) -> np.ndarray:
        return np.stack(self.env_method("action_masks"))

    def get_state(self) -> bytes:
        return pickle.dumps((self.envs, self._seeds, self.buf_obs, self.buf_dones, self.buf_rews))

    def set_state(self, state: bytes) -> None:
        self.envs, self._seeds, self.buf_obs, self.buf_dones, self.buf_rews = pickle.loads(state)
