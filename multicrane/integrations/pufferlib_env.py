"""Native PufferLib 3 environments over the vector envs: one agent per copy, or per crane.

    import pufferlib.vector
    from multicrane.integrations.pufferlib_env import MotionPufferEnv, PaperPufferEnv

    env = PaperPufferEnv(num_envs=4096, config="E1S1")     # 4096 agents, one per copy
    env = MotionPufferEnv(num_envs=256, scenario="hall-4c", n_cranes=4)  # 1024 agents
    vecenv = pufferlib.vector.make(MotionPufferEnv, env_kwargs=dict(num_envs=256, ...))

Needs the ``pufferlib`` extra and PufferLib 3.0.0 itself, which PyPI serves only as a source
archive that does not build as published: ``tools/test_pufferlib.sh`` installs it
(docs/vector.md, "PufferLib").

- ``PaperPufferEnv``: ``multicrane.vector.PaperVectorEnv`` as a ``pufferlib.PufferEnv``; agent
  ``i`` is copy ``i``.
- ``MotionPufferEnv``: ``multicrane.vector.motion_vector_env.MotionVectorEnv``; agent
  ``b * n_cranes + k`` is crane ``k`` of copy ``b``.

Both are native: PufferLib's trainer reads ``observations``, ``rewards``, ``terminals``,
``truncations`` and ``masks`` and writes ``actions`` with no emulation layer. Made by PufferLib
itself (its ``PufferEnv`` backend: no ``buf``), the env hands PufferLib the vector env's own
observation and flag arrays, which the kernels overwrite in place each step (no copy; rewards
are cast into PufferLib's float32 array). Given PufferLib's buffers (``buf``, as its ``Serial``
and ``Multiprocessing`` backends do), it copies into them. ``masks`` are PufferLib's agent
masks: every agent acts every step (autoreset), so they stay True; the legal actions are in
``action_masks()``, ``[num_agents, A]``, which PufferLib's trainer does not read (a masked
action is accepted and does nothing, as in the one-site env). ``infos`` is a list: one dict
of means over the episodes that ended in the step (``episode_return`` per agent,
``episode_length``, ``is_success``, ``episodes``), or none.
"""

from __future__ import annotations

import os
import sys
import tempfile

import numpy as np

from multicrane.vector.motion_vector_env import MotionVectorEnv
from multicrane.vector.paper_vector_env import PaperVectorEnv


def _import_pufferlib():
    """``import pufferlib``; its 3.0.0 ``__init__`` links ``resources`` into the working
    directory, so a first import runs in a temporary one (removed after)."""
    if "pufferlib" not in sys.modules:
        here = os.getcwd()
        with tempfile.TemporaryDirectory() as scratch:
            os.chdir(scratch)
            try:
                import pufferlib  # noqa: F401
            finally:
                os.chdir(here)
    return sys.modules["pufferlib"]


pufferlib = _import_pufferlib()


class _VectorPufferEnv(pufferlib.PufferEnv):
    """A vector env as a native ``PufferEnv``, one agent per action of its joint action.
    Subclasses make ``self.vector`` and call ``_start``."""

    vector: PaperVectorEnv | MotionVectorEnv

    def _start(self, action_shape: tuple, buf: dict | None, seed: int | None) -> None:
        """Declare the spaces and agents (``action_shape``: the vector env's actions), then let
        PufferLib make (or give) its buffers."""
        self.single_observation_space = self.vector.single_observation_space
        self.single_action_space = self.vector.single_action_space
        self.num_agents = int(np.prod(action_shape))
        self.action_shape = action_shape
        self.render_mode = None
        super().__init__(buf)
        self.own_buffers = buf is None  # PufferLib reads the vector env's arrays themselves
        self.masks[:] = True
        self.seed = seed
        self.episode_returns = np.zeros(self.num_agents, dtype=np.float64)
        self.episode_lengths = np.zeros(self.num_agents, dtype=np.int64)

    def reset(self, seed: int | None = None):
        """Reset every copy (``seed``: as the vector env's; None the first time: the ``seed``
        the env was made with); returns the observations and an empty info list."""
        if seed is None:
            seed, self.seed = self.seed, None
        outputs = self.vector.reset(seed=seed)
        self._publish(outputs[0], None, None, None)
        self.rewards[:] = 0
        self.terminals[:] = False
        self.truncations[:] = False
        self.episode_returns[:] = 0
        self.episode_lengths[:] = 0
        return self.observations, []

    def step(self, actions):
        """One step of every copy with ``actions`` ``[num_agents]``; PufferLib's five outputs."""
        actions = np.asarray(actions).reshape(self.action_shape)
        obs, rewards, terminated, truncated, _ = self.vector.step(actions)
        self._publish(obs, rewards, terminated, truncated)
        return self.observations, self.rewards, self.terminals, self.truncations, self._logs()

    def _publish(self, obs, rewards, terminated, truncated) -> None:
        """Show the vector env's outputs to PufferLib: its own arrays (as views with one row
        per agent) when PufferLib gave no buffers, else copied into PufferLib's."""
        outputs = {"observations": obs, "terminals": terminated, "truncations": truncated}
        for name, array in outputs.items():
            if array is None:
                continue
            rows = array.reshape(self.num_agents, *getattr(self, name).shape[1:])
            if self.own_buffers:
                setattr(self, name, rows)
            else:
                getattr(self, name)[:] = rows
        if rewards is not None:
            self.rewards[:] = rewards.reshape(self.num_agents)

    def _logs(self) -> list[dict]:
        """The means over the episodes that ended in this step (none: an empty list)."""
        self.episode_returns += self.rewards
        self.episode_lengths += 1
        done = self.terminals | self.truncations
        if not done.any():
            return []
        logs = {
            "episode_return": float(self.episode_returns[done].mean()),
            "episode_length": float(self.episode_lengths[done].mean()),
            "is_success": float(self.terminals[done].mean()),
            "episodes": int(done.sum()),
        }
        self.episode_returns[done] = 0
        self.episode_lengths[done] = 0
        return [logs]

    def action_masks(self) -> np.ndarray:
        """The legal actions of every agent, ``[num_agents, A]`` int8 (a copy)."""
        return self.vector.action_masks().reshape(self.num_agents, -1)

    def close(self) -> None:
        """Close the vector env."""
        self.vector.close()


class PaperPufferEnv(_VectorPufferEnv):
    """``PaperVectorEnv(num_envs, config, scenario, mask_blocked_moves, obs_dtype)`` as a
    native PufferLib env: ``num_envs`` agents, agent ``i`` copy ``i``. ``buf`` and ``seed``
    are PufferLib's (its vector backends pass them)."""

    def __init__(
        self,
        num_envs: int = 1,
        config: str | None = "E1S1",
        scenario=None,
        mask_blocked_moves: bool = False,
        obs_dtype=np.float32,
        buf: dict | None = None,
        seed: int | None = None,
    ):
        self.vector = PaperVectorEnv(
            num_envs, config=config, scenario=scenario, mask_blocked_moves=mask_blocked_moves,
            obs_dtype=obs_dtype,
        )  # fmt: skip
        self._start((self.vector.num_envs,), buf, seed)


class MotionPufferEnv(_VectorPufferEnv):
    """``MotionVectorEnv(num_envs, scenario, n_cranes, **options)`` as a native PufferLib
    env: ``num_envs * n_cranes`` agents, agent ``b * n_cranes + k`` crane ``k`` of copy
    ``b``. ``options`` are the vector env's (``max_steps``, ``reward``, ``reward_mode``,
    ``events``, ...); ``buf`` and ``seed`` are PufferLib's."""

    def __init__(
        self,
        num_envs: int = 1,
        scenario="e2s2",
        n_cranes: int | None = None,
        buf: dict | None = None,
        seed: int | None = None,
        **options,
    ):
        self.vector = MotionVectorEnv(num_envs, scenario, n_cranes, **options)
        self._start((self.vector.num_envs, self.vector.n_cranes), buf, seed)
