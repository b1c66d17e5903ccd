"""``PaperVectorEnv``: B copies of one paper configuration as a Gymnasium ``VectorEnv``.

``gymnasium.make_vec("multicrane/PaperAssembly-E1S1-v0", num_envs=B,
vectorization_mode="vector_entry_point")`` returns one (docs/vector.md). Each copy is the MDP
of ``PaperAssemblyEnv`` (docs/paper-spec.md), step for step and number for number; the
copies live in the arrays of ``multicrane.vector.paper_state`` and are stepped, observed,
masked and reset by the kernels of ``multicrane.vector.paper_step`` in one call.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from multicrane.core.codes import N_MOVES
from multicrane.core.schema import Scenario
from multicrane.envs.boundary import as_integer, require_reset
from multicrane.envs.paper_env import PaperAssemblyEnv
from multicrane.vector.copies import Copies
from multicrane.vector.paper_reset import reset_copies
from multicrane.vector.paper_site import compile_site
from multicrane.vector.paper_state import allocate
from multicrane.vector.paper_step import step_batch

MOVES_TEXT = "0..5 (x-1, y-1, x+1, y+1, up, down)"


class PaperVectorEnv(Copies, VectorEnv):
    """``num_envs`` copies of ``PaperAssemblyEnv(config, scenario, mask_blocked_moves)``.

    **Spaces.** ``single_observation_space`` is the one-site env's ``Box(0, high, (1350,))``
    (``obs_dtype=np.uint8`` gives the same values as bytes); ``single_action_space`` is
    ``Discrete(6)``; the batched spaces have a leading axis of ``num_envs``.

    **Seeds.** ``reset(seed=s)`` seeds copy ``i`` with the ``i``-th child of
    ``np.random.SeedSequence(s)`` (``PCG64``); ``reset(seed=[s0, s1, ...])`` gives copy ``i``
    the generator of ``PaperAssemblyEnv.reset(seed=si)``; ``reset()`` without a seed draws
    fresh entropy the first time and then goes on with each copy's generator. A copy draws
    its starts from its generator exactly as the one-site env does with the same generator.

    **Autoreset: same step** (``metadata["autoreset_mode"]`` is ``AutoresetMode.SAME_STEP``).
    A copy whose episode ends in a step is reset in that step: ``step`` returns the first
    observation of its new episode, the reward, ``terminated`` and ``truncated`` of the step
    that ended the old one, and that episode's last observation in ``infos["final_obs"]``
    (rows where ``infos["_final_obs"]``).

    **Infos** (arrays over the copies, each with its ``_key`` mask): ``event_counts``
    ``[B, len(EventType)]`` of the step; ``component_index`` (the component the next action
    moves, -1 none; after an autoreset, the new episode's); ``is_success`` where an episode
    ended; ``final_obs`` as above.

    **Buffers.** ``step`` and ``reset`` return the env's own arrays, written in place by the
    next call (no copy per step); pass ``copy=True`` to get fresh arrays instead.

    **Errors.** As the one-site env's, naming the copy: an action that is not an integer, an
    array of the wrong shape, an action outside 0..5, a call before ``reset()``.
    """

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": []}

    def __init__(
        self,
        num_envs: int = 1,
        config: str | None = "E1S1",
        scenario: str | Scenario | None = None,
        mask_blocked_moves: bool = False,
        obs_dtype: Any = np.float32,
        copy: bool = False,
    ):
        n = self._set_up_copies(num_envs, copy)
        reference = PaperAssemblyEnv(config=config, scenario=scenario)
        dtype = np.dtype(obs_dtype)
        if dtype not in (np.float32, np.uint8):
            raise ValueError(f"obs_dtype must be float32 or uint8, got {dtype}")
        self.config = reference.config
        self.scenario = reference.scenario
        self.mask_blocked_moves = bool(mask_blocked_moves)
        self.render_mode = None
        box = reference.observation_space
        self.single_observation_space = spaces.Box(0, box.high.max(), box.shape, dtype)
        self.single_action_space = spaces.Discrete(N_MOVES)
        self.observation_space = batch_space(self.single_observation_space, n)
        self.action_space = batch_space(self.single_action_space, n)
        self.site = compile_site(self.scenario)
        self.state, self.buffers = allocate(self.site, n, dtype)

    # -- episodes ----------------------------------------------------------------------------

    def reset(self, *, seed: int | Sequence[int | None] | None = None, options=None):
        """Reset every copy (see the class doc for ``seed``); ``options`` are ignored, as
        ``PaperAssemblyEnv`` ignores them."""
        self._seed(seed)
        failed = reset_copies(
            self.site, self.state, self.buffers, self._all, self.mask_blocked_moves
        )
        return self._reset_outputs(failed)

    def step(self, actions):
        """One step of every copy (autoresets included); see the class doc."""
        require_reset(self._started, "step")
        a = self._actions(actions)
        bad, failed = step_batch(
            self.site, self.state, self.buffers, a, self.mask_blocked_moves, True
        )
        if bad >= 0:
            _out_of_range(bad, a[bad])
        return self._step_outputs(failed)

    def _actions(self, actions) -> np.ndarray:
        """The actions as an int64 array of shape (num_envs,); else the one-site env's errors,
        naming the copy (those outside 0..5 are found by the kernel, before it steps)."""
        a = np.asarray(actions)
        if a.shape != (self.num_envs,):
            raise ValueError(
                f"step(): actions must have shape ({self.num_envs},) (one per copy), "
                f"got {a.shape}"
            )
        if a.dtype != bool and np.issubdtype(a.dtype, np.integer):
            return a if a.dtype == np.int64 else a.astype(np.int64)
        for copy, value in enumerate(a.tolist()):
            action = as_integer(value, f"step(): copy {copy}: action")  # a float, bool, str
            if not 0 <= action < N_MOVES:
                _out_of_range(copy, action)
        return a.astype(np.int64)  # Python ints, each in range

    def _infos(self) -> dict[str, np.ndarray]:
        buf, out = self.buffers, self._out
        return {
            "event_counts": out(buf.event_counts),
            "_event_counts": self._all,
            "component_index": out(buf.component_index),
            "_component_index": self._all,
            "is_success": buf.terminated.copy(),
            "_is_success": self._done.copy(),
            **self._final_obs_infos(),
        }


def _out_of_range(copy: int, action: int) -> None:
    raise ValueError(f"step(): copy {copy}: action must be {MOVES_TEXT}, got {action}")
