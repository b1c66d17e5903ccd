"""The plumbing the vector envs share: the copy count, seeding, buffer copies, errors, queries.

``Copies`` is a mixin of ``PaperVectorEnv``, ``MotionVectorEnv`` and ``TaskVectorEnv``: each
keeps its kernels, its arrays (``state``, ``buffers``, and those its ``SNAPSHOT`` names) and
its own ``_infos``; this holds what they do alike around them (docs/vector.md).
``CraneCopies`` adds what the envs with one action per copy and crane share: the actions'
checks and the masks' (``strict``), with the one-site env's errors naming the copy and crane.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from multicrane.core.schema import ScenarioError
from multicrane.envs.boundary import as_integer, require_reset
from multicrane.vector.pcg64 import generator_of, seed_states


class Copies:
    """What a vector env of ``num_envs`` copies does alike in either mode: it sets
    ``num_envs``, ``copy``, ``_all``, ``_done`` and ``_started``, and reads the subclass's
    ``scenario``, ``state`` (with ``rng``), ``buffers`` (with ``obs``, ``masks``, ``rewards``,
    ``terminated``, ``truncated``, ``event_counts``, ``final_obs``) and ``_infos()``."""

    scenario: Any
    state: Any
    buffers: Any
    # The arrays a snapshot holds: named tuples that ``set_state`` replaces with copies (they
    # may differ in size), then those it writes into in place (they may not).
    SNAPSHOT: tuple[tuple[str, ...], tuple[str, ...]] = (("state",), ("buffers",))

    def _set_up_copies(self, num_envs: int, copy: bool) -> int:
        """Check and keep the copy count (ValueError below 1) and ``copy``; returns the count."""
        n = as_integer(num_envs, "num_envs")
        if n < 1:
            raise ValueError(f"num_envs must be at least 1, got {n}")
        self.num_envs = n
        self.copy = bool(copy)
        self._all = np.ones(n, dtype=bool)
        self._done = np.zeros(n, dtype=bool)
        self._started = False
        return n

    def _seed(self, seed: int | Sequence[int | None] | None) -> None:
        """Seed every copy's generator for ``reset`` (fresh entropy the first time without)."""
        if seed is not None or not self._started:
            seed_states(self.state.rng, seed)
        self._started = True

    def _reset_outputs(self, failed: int, *more: np.ndarray):
        """``reset``'s return once the kernel has reset every copy (``failed``: the first copy
        with no start, else -1): the step outputs (and ``more``) cleared, observations, infos."""
        if failed >= 0:
            self._no_start(failed)
        buf = self.buffers
        for array in (buf.event_counts, buf.rewards, buf.terminated, buf.truncated, *more):
            array[:] = 0
        self._done[:] = False
        return self._out(buf.obs), self._infos()

    def _step_outputs(self, failed: int):
        """``step``'s return once the kernel has run (``failed``: the first copy whose
        autoreset found no start, else -1); ``_done`` is ``terminated`` or ``truncated``."""
        if failed >= 0:
            self._no_start(failed)
        buf = self.buffers
        np.logical_or(_per_copy(buf.terminated), _per_copy(buf.truncated), out=self._done)
        out = self._out
        return (out(buf.obs), out(buf.rewards), out(buf.terminated), out(buf.truncated),
                self._infos())  # fmt: skip

    def _no_start(self, copy: int) -> None:
        raise ScenarioError(
            f"{self.scenario.source}: copy {copy}: no start found (no free target for a "
            f"pre-built component, or no random layout in the allowed attempts)"
        )

    def _out(self, array: np.ndarray) -> np.ndarray:
        return array.copy() if self.copy else array

    def _final_obs_infos(self) -> dict[str, np.ndarray]:
        """The infos of the episodes that ended in the step: ``final_obs`` and its mask."""
        return {"final_obs": self._out(self.buffers.final_obs), "_final_obs": self._done.copy()}

    # -- queries -----------------------------------------------------------------------------

    def action_masks(self) -> np.ndarray:
        """Each copy's one-site ``action_masks()``, leading axis ``num_envs`` (int8, a copy):
        ``[num_envs, 6]`` in the paper mode, ``[num_envs, n_cranes, 8 + C]`` in the motion
        mode."""
        require_reset(self._started, "action_masks")
        return self.buffers.masks.copy()

    def get_state(self) -> dict[str, Any]:
        """A snapshot of every copy (state arrays, generators included, output buffers and
        flags) that ``set_state`` restores: the copies then go on exactly as from here."""
        replaced, written = self.SNAPSHOT
        saved = {name: [a.copy() for a in getattr(self, name)] for name in replaced + written}
        return {**saved, "started": self._started, "done": self._done.copy()}

    def set_state(self, saved: dict[str, Any]) -> None:
        """Return every copy to a ``get_state`` snapshot of an env of the same scenario,
        options and copy count (ValueError naming the array that does not fit). State arrays
        may differ in size (the motion env's event tables grow); buffers may not."""
        replaced, written = self.SNAPSHOT
        for name in replaced + written:
            arrays = getattr(self, name)
            if len(saved[name]) != len(arrays):
                raise ValueError(f"saved vector env {name}: {len(saved[name])} arrays, "
                                 f"expected {len(arrays)}")  # fmt: skip
            for field, array, value in zip(arrays._fields, arrays, saved[name], strict=True):
                if value.dtype != array.dtype or (name in written and value.shape != array.shape):
                    raise ValueError(f"saved vector env {name}.{field}: {value.dtype}"
                                     f"{value.shape}, expected {array.dtype}{array.shape}")
        for name in replaced:
            setattr(self, name, type(getattr(self, name))(*(a.copy() for a in saved[name])))
        for name in written:
            for array, value in zip(getattr(self, name), saved[name], strict=True):
                array[...] = value
        self._started = bool(saved["started"])
        self._done[:] = saved["done"]

    def generator(self, copy: int) -> np.random.Generator:
        """A numpy generator in copy ``copy``'s present state (the copy's own goes on
        unchanged): the one its next draws (crane orders, starts) will come from."""
        if not 0 <= as_integer(copy, "copy") < self.num_envs:
            raise IndexError(f"copy {copy} out of range 0..{self.num_envs - 1}")
        return generator_of(self.state.rng[copy])


class CraneCopies(Copies):
    """``Copies`` with one action per copy and crane (``n_cranes``, ``n_actions``,
    ``strict``, ``buffers.masks`` ``[B, N, A]`` and the one-site ``reference`` env's words for
    an action); the kernels check the range and name the first action outside it."""

    n_cranes: int
    n_actions: int
    reference: Any

    def _actions(self, actions) -> np.ndarray:
        """The actions as a C-ordered int64 array of shape (num_envs, n_cranes) (the type
        the kernels were called with); else the one-site env's errors, naming the copy and
        the crane."""
        a = actions if isinstance(actions, np.ndarray) else np.asarray(actions)
        shape = (self.num_envs, self.n_cranes)
        if a.shape != shape:
            raise ValueError(
                f"step(): actions must have shape {shape} (one per copy and crane), got {a.shape}"
            )
        if a.dtype == bool or not np.issubdtype(a.dtype, np.integer):
            for (copy, crane), value in np.ndenumerate(a):
                action = as_integer(value, f"step(): copy {copy}: the action of crane_{crane}")
                if not 0 <= action < self.n_actions:
                    self._out_of_range(copy, crane, action)
        return np.ascontiguousarray(a, dtype=np.int64)

    def _out_of_range(self, copy: int, crane: int, action: int) -> None:
        raise ValueError(
            f"step(): copy {copy}: crane_{crane} sent action {action}, "
            f"outside 0..{self.n_actions - 1}"
        )

    def _check_masks(self, a: np.ndarray) -> None:
        """``strict``: the first action the masks do not allow (one out of range is left to
        the kernel's check) is refused, naming the copy, the crane and the action."""
        inside = (a >= 0) & (a < self.n_actions)
        clipped = np.clip(a, 0, self.n_actions - 1)[..., None]
        legal = np.take_along_axis(self.buffers.masks, clipped, axis=2)
        bad = np.argwhere(inside & (legal[..., 0] == 0))
        if len(bad):
            copy, crane = (int(v) for v in bad[0])
            what = self.reference.mode.describe(int(a[copy, crane]))
            raise ValueError(
                f"step(): copy {copy}: crane_{crane} sent illegal action "
                f"{a[copy, crane]} ({what})"
            )


def _per_copy(flags: np.ndarray) -> np.ndarray:
    """A copy's flag: the array itself (one per copy) or its first crane's (all share it)."""
    return flags if flags.ndim == 1 else flags[:, 0]
