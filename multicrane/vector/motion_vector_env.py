"""``MotionVectorEnv``: B copies of one scenario in the multi-agent motion mode, stepped together.

Each copy is the MDP of ``multicrane.parallel_env(scenario, obs_format="flat", ...)`` in the
motion mode (``auto=False``: cranes claim, move and assemble by action), step for step and
number for number, the crane order of every step and the start of every episode drawn from
the copy's generator as the one-site env draws them. The copies live in the arrays of
``multicrane.vector.motion_state`` and are stepped, observed, masked and reset by the kernels
of ``multicrane.vector.motion_step`` in one call (docs/vector.md).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from multicrane.core.schema import Scenario
from multicrane.envs.boundary import require_reset
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.sim.events import EventSpec
from multicrane.vector.copies import CraneCopies
from multicrane.vector.event_schedules import draw_schedules
from multicrane.vector.motion_site import compile_motion_site, obs_scale
from multicrane.vector.motion_state import allocate
from multicrane.vector.motion_step import finish_resets, reset_copies, step_batch


class MotionVectorEnv(CraneCopies):
    """``num_envs`` copies of ``MultiCraneEnv(scenario, n_cranes, obs_format="flat", ...)``
    with motion-level decisions.

    **Arrays.** ``reset`` and ``step`` return observations ``[B, N, D]`` (float32; row ``k``
    is ``crane_k``'s flat observation), rewards ``[B, N]`` (float64: the team reward, or each
    crane's share with ``reward_mode="split"``), terminations and truncations ``[B, N]``
    (bool; every crane of a copy shares them, as in the one-site env) and infos;
    ``action_masks()`` is ``[B, N, 8 + C]`` (int8). Actions are ``[B, N]`` integers.

    **Options.** ``scenario``, ``n_cranes``, ``max_steps``, ``max_cycles``, ``reward``,
    ``reward_mode``, ``strict`` and ``events`` as ``MultiCraneEnv``; crane reach comes from the
    scenario. The other decision levels and the automatic mode are not modelled.

    **Site events** (``events``: None for the scenario's ``[events]`` table if any, a level
    ``"none"``, ``"low"``, ``"high"``, or an ``EventSpec``; docs/uncertainty.md): each copy's
    schedule is drawn at each reset from its generator as the one-site env draws it (numpy's
    own draws, ``multicrane.vector.event_schedules``), and applied in the kernels: late
    deliveries, breakdowns, closed zones, the events block of the observation, the masks.

    **Seeds.** ``reset(seed=s)`` seeds copy ``i`` with the ``i``-th child of
    ``np.random.SeedSequence(s)``; ``reset(seed=[s0, s1, ...])`` gives copy ``i`` the
    generator of ``MultiCraneEnv.reset(seed=si)``; ``reset()`` goes on with each copy's
    generator (fresh entropy the first time). Each step draws the crane order from it.

    **Autoreset: same step.** A copy whose episode ends in a step is reset in that step: the
    step returns the first observation of its new episode with the reward and flags of the
    step that ended the old one, and that episode's last observations in
    ``infos["final_obs"]`` (copies where ``infos["_final_obs"]``).

    **Infos** (arrays over the copies): ``event_counts`` ``[B, N, len(EventType)]`` and
    ``reward_term`` ``[B, N]``, as the one-site env's per-crane infos; ``final_obs``; with site
    events ``site_event_counts`` ``[B, len(SiteEventType)]`` (the one-site env gives every
    crane the same counts; after an autoreset, those of the step that ended the episode).

    **Buffers.** ``step`` and ``reset`` return the env's own arrays, written in place by the
    next call; ``copy=True`` returns fresh arrays instead.

    **uint8 observations** (``obs_dtype=np.uint8``): every feature as a whole number, its
    fraction's numerator: ``obs.astype(np.float32) / env.obs_scale`` is the float32
    observation bit for bit, but for the crane vector's step fraction, rounded down to
    1/255 (its divisor, the step limit, does not fit a byte). A quarter of the memory.

    **Errors.** As the one-site env's, naming the copy and the crane: an action that is not
    an integer or outside ``0..8 + C - 1``, a wrong shape, a masked action with
    ``strict=True``, a call before ``reset()``.
    """

    def __init__(
        self,
        num_envs: int = 1,
        scenario: str | Path | Scenario = "e2s2",
        n_cranes: int | None = None,
        max_steps: int | None = None,
        max_cycles: int | None = None,
        reward: str = "paper",
        reward_mode: str = "team",
        strict: bool = False,
        events: EventSpec | str | None = None,
        copy: bool = False,
        obs_dtype: Any = np.float32,
    ):
        n = self._set_up_copies(num_envs, copy)
        dtype = np.dtype(obs_dtype)
        if dtype not in (np.float32, np.uint8):
            raise ValueError(f"obs_dtype must be float32 or uint8, got {dtype}")
        self.reference = MultiCraneEnv(
            scenario, n_cranes, max_steps=max_steps, max_cycles=max_cycles, reward=reward,
            reward_mode=reward_mode, obs_format="flat", events=events,
        )  # fmt: skip
        self.scenario = self.reference.scenario
        whole = dtype == np.uint8
        self.site = compile_motion_site(self.reference, whole)
        self.n_cranes = self.site.n_cranes
        self.n_actions = self.reference.n_actions
        self.strict = bool(strict)
        box = self.reference.observation_space("crane_0")
        self.obs_scale = obs_scale(self.reference, self.site) if whole else None
        if whole:
            box = spaces.Box(0, self.obs_scale.astype(np.uint8), box.shape, dtype)
        self.single_observation_space = box
        self.single_action_space = spaces.Discrete(self.n_actions)
        self.state, self.buffers = allocate(self.site, n, dtype)

    # -- episodes ----------------------------------------------------------------------------

    def reset(self, *, seed: int | Sequence[int | None] | None = None, options=None):
        """Reset every copy (see the class doc for ``seed``)."""
        self._seed(seed)
        failed = reset_copies(self.site, self.state, self.buffers, self._all)
        if failed < 0:
            self._schedule_resets(count=True)
        return self._reset_outputs(failed, self.buffers.terms)

    def step(self, actions):
        """One joint step of every copy (autoresets included); see the class doc."""
        require_reset(self._started, "step")
        a = self._actions(actions)
        if self.strict:
            self._check_masks(a)
        bad_copy, bad_crane, failed = step_batch(self.site, self.state, self.buffers, a, True)
        if bad_copy >= 0:
            self._out_of_range(bad_copy, bad_crane, a[bad_copy, bad_crane])
        if failed < 0:
            self._schedule_resets(count=False)
        return self._step_outputs(failed)

    def _schedule_resets(self, count: bool) -> None:
        """With site events: draw the schedules of the copies the kernel reset up to their
        start, and complete those resets (their time-0 site events counted when ``count``)."""
        copies = np.flatnonzero(self.buffers.scheduling)
        if len(copies) == 0:
            return
        sim = self.reference.sim
        self.state = draw_schedules(
            sim.events, sim.site, self.n_cranes, sim.horizon, self.state, copies
        )
        finish_resets(self.site, self.state, self.buffers, count)

    def _infos(self) -> dict[str, np.ndarray]:
        buf, out = self.buffers, self._out
        infos = {
            "event_counts": out(buf.event_counts),
            "reward_term": out(buf.terms),
            **self._final_obs_infos(),
        }
        if self.site.has_events:
            infos["site_event_counts"] = out(buf.site_counts)
        return infos

    def close(self) -> None:
        """Nothing to release (the arrays go with the env)."""
