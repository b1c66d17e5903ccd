"""Throughput of the vector envs: steps per second, bytes per copy, compile and start times.

``multicrane bench --vector`` prints these beside the one-site envs' figures. Random actions
are drawn by compiled samplers (``sample_moves``: uniform moves for the paper env;
``sample_legal``: a uniform legal action per crane from the masks for the motion env;
``sample_tasks``: a uniform allowed task per idle crane for the task env, as
``policies.task_planners.TaskRandom`` chooses), so the clock sees ``env.step`` (its checks,
the kernel, the infos) and not a Python loop over the copies. ``task_round_seconds`` times
the task env's decision rounds one by one, the chooser's call included, as
``multicrane bench --decisions task`` times the one-site env's.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time

import numpy as np

from multicrane.core.codes import N_MOVES
from multicrane.vector.compiled import kernel
from multicrane.vector.motion_vector_env import MotionVectorEnv
from multicrane.vector.paper_state import nbytes
from multicrane.vector.paper_vector_env import PaperVectorEnv
from multicrane.vector.pcg64 import bounded, state_of
from multicrane.vector.task_vector_env import TaskVectorEnv

# A second process: the seconds from its first line to its first step done.
_FIRST_STEP = """
import time
begun = time.perf_counter()
import numpy as np
from multicrane.vector.paper_vector_env import PaperVectorEnv
env = PaperVectorEnv(1, config={config!r})
env.reset(seed=0)
env.step(np.zeros(1, dtype=np.int64))
print(time.perf_counter() - begun)
"""
_FIRST_MOTION_STEP = """
import time
begun = time.perf_counter()
import numpy as np
from multicrane.vector.motion_vector_env import MotionVectorEnv
env = MotionVectorEnv(1, {scenario!r}, n_cranes={cranes!r})
env.reset(seed=0)
env.step(np.full((1, env.n_cranes), 6, dtype=np.int64))
print(time.perf_counter() - begun)
"""
_FIRST_TASK_STEP = """
import time
begun = time.perf_counter()
from multicrane.vector.task_vector_env import TaskVectorEnv
env = TaskVectorEnv(1, {scenario!r}, n_cranes={cranes!r})
env.reset(seed=0)
env.step(env.propose())
print(time.perf_counter() - begun)
"""


@kernel
def sample_moves(rng, out):
    """Uniform random moves into ``out`` from the generator in ``rng[0]``."""
    for i in range(len(out)):
        out[i] = bounded(rng, 0, N_MOVES)


@kernel
def sample_legal(rng, masks, out):
    """A uniform legal action per copy and crane into ``out`` ([B, N]) from the masks
    ([B, N, A]), drawn from the generator in ``rng[0]``."""
    for b in range(masks.shape[0]):
        for k in range(masks.shape[1]):
            n = 0
            for a in range(masks.shape[2]):
                n += masks[b, k, a]
            pick = bounded(rng, 0, n)
            for a in range(masks.shape[2]):
                if masks[b, k, a]:
                    if pick == 0:
                        out[b, k] = a
                        break
                    pick -= 1


@kernel
def sample_tasks(rng, masks, out):
    """A uniform allowed task per copy and crane into ``out`` ([B, N]) from the task masks
    ([B, N, 1 + P]), 0 (wait) where none, drawn from the generator in ``rng[0]``."""
    for b in range(masks.shape[0]):
        for k in range(masks.shape[1]):
            n = 0
            for a in range(1, masks.shape[2]):
                n += masks[b, k, a]
            out[b, k] = 0
            if n == 0:
                continue
            pick = bounded(rng, 0, n)
            for a in range(1, masks.shape[2]):
                if masks[b, k, a]:
                    if pick == 0:
                        out[b, k] = a
                        break
                    pick -= 1


def task_env(scenario, cranes: int | None, num_envs: int = 1) -> TaskVectorEnv:
    return TaskVectorEnv(num_envs, scenario, n_cranes=cranes)


def task_round_seconds(scenario, cranes: int | None, rounds: int, policy: str,
                       num_envs: int = 1, seed: int = 0) -> np.ndarray:  # fmt: skip
    """Seconds of each of ``rounds`` decision rounds of ``TaskVectorEnv`` (``num_envs``
    copies at once): the chooser's call (``"prioritized"``: ``env.propose()``; ``"random"``:
    ``sample_tasks``) plus ``env.step``, after 300 copy-rounds of warm-up, from seed
    ``seed``."""
    env = task_env(scenario, cranes, num_envs)
    env.reset(seed=seed)
    rng = state_of(np.random.default_rng(seed))[None].copy()
    actions = np.zeros((num_envs, env.n_cranes), dtype=np.int64)
    masks = env.buffers.masks

    def choose():
        if policy == "prioritized":
            return env.propose()
        sample_tasks(rng, masks, actions)
        return actions

    if policy not in ("prioritized", "random"):
        raise ValueError(f"policy must be prioritized or random, got {policy!r}")
    for _ in range(max(2, 300 // num_envs)):
        env.step(choose())
    seconds = np.empty(rounds)
    for i in range(rounds):
        begun = time.perf_counter()
        env.step(choose())
        seconds[i] = time.perf_counter() - begun
    return seconds


def task_bytes_per_copy(scenario, cranes: int | None, num_envs: int) -> float:
    """Bytes per copy of the task env's state and buffers (the site's and the task book's;
    the kernels' scratch space is the env's, shared by the copies, and not counted)."""
    env = task_env(scenario, cranes, num_envs)
    arrays = (env.state, env.motion_buffers, env.tasks, env.buffers)
    return sum(nbytes(a) for a in arrays) / num_envs


def motion_steps_per_second(
    scenario: str,
    cranes: int | None,
    num_envs: int,
    seconds: float = 0.5,
    seed: int = 0,
    events: str | None = None,
    obs_dtype=np.float32,
) -> float:
    """Joint copy-steps per second of ``MotionVectorEnv.step`` under uniform random legal
    actions (resets included when episodes end), timed over at least ``seconds``; ``events``:
    a site-events level (None: the scenario's own); ``obs_dtype``: the env's."""
    env = MotionVectorEnv(num_envs, scenario, n_cranes=cranes, events=events, obs_dtype=obs_dtype)
    env.reset(seed=seed)
    rng = state_of(np.random.default_rng(seed))[None].copy()
    actions = np.zeros((num_envs, env.n_cranes), dtype=np.int64)
    masks = env.buffers.masks  # the env's own, up to date after every step
    sample_legal(rng, masks, actions)
    env.step(actions)
    calls, begun = 0, time.perf_counter()
    while True:
        sample_legal(rng, masks, actions)
        env.step(actions)
        calls += 1
        elapsed = time.perf_counter() - begun
        if elapsed >= seconds:
            return calls * num_envs / elapsed


def motion_bytes_per_copy(
    scenario: str, cranes: int | None, num_envs: int, obs_dtype=np.float32
) -> float:
    """Bytes of the motion env's state and buffers per copy (observations in ``obs_dtype``)."""
    env = MotionVectorEnv(num_envs, scenario, n_cranes=cranes, obs_dtype=obs_dtype)
    return (nbytes(env.state) + nbytes(env.buffers)) / num_envs


def steps_per_second(config: str, num_envs: int, seconds: float = 0.5, seed: int = 0) -> float:
    """Copy-steps per second of ``PaperVectorEnv.step`` under uniform random moves (resets
    included when episodes end), timed over at least ``seconds`` after a warm-up step."""
    env = PaperVectorEnv(num_envs, config=config)
    env.reset(seed=seed)
    rng = state_of(np.random.default_rng(seed))[None].copy()
    actions = np.zeros(num_envs, dtype=np.int64)
    sample_moves(rng, actions)
    env.step(actions)
    calls, begun = 0, time.perf_counter()
    while True:
        sample_moves(rng, actions)
        env.step(actions)
        calls += 1
        elapsed = time.perf_counter() - begun
        if elapsed >= seconds:
            return calls * num_envs / elapsed


def bytes_per_copy(config: str, num_envs: int) -> float:
    """Bytes of the state and buffers of ``num_envs`` copies, divided by ``num_envs``."""
    env = PaperVectorEnv(num_envs, config=config)
    return (nbytes(env.state) + nbytes(env.buffers)) / num_envs


def start_seconds(
    config: str, cranes: int | None = None, task: bool = False
) -> tuple[float, float]:
    """(first process, second process): seconds from a fresh Python's first line to its
    first step, with an empty numba cache (the compile) and then with the cache it left;
    ``cranes`` given: of the motion env on scenario ``config`` (``task``: the task env, its
    first round with the compiled rule), else the paper env."""
    if cranes is None:
        script = _FIRST_STEP.format(config=config)
    else:
        template = _FIRST_TASK_STEP if task else _FIRST_MOTION_STEP
        script = template.format(scenario=config, cranes=cranes)
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        runs = [
            subprocess.run([sys.executable, "-c", script], env=env, check=True,
                           capture_output=True, text=True)  # fmt: skip
            for _ in range(2)
        ]
    first, second = (float(r.stdout.split()[-1]) for r in runs)
    return first, second
