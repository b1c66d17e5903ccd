"""Throughput of the vector envs: steps per second, bytes per copy, compile and start times.

``multicrane bench --vector`` prints these beside the one-site envs' figures. Random actions
are drawn by compiled samplers (``sample_moves``: uniform moves for the paper env;
``sample_legal``: a uniform legal action per crane from the masks for the motion env), so
the clock sees ``env.step`` (its checks, the kernel, the infos) and not a Python loop over
the copies.
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


def start_seconds(config: str, cranes: int | None = None) -> tuple[float, float]:
    """(first process, second process): seconds from a fresh Python's first line to its
    first step, with an empty numba cache (the compile) and then with the cache it left;
    ``cranes`` given: of the motion env on scenario ``config``, else the paper env."""
    if cranes is None:
        script = _FIRST_STEP.format(config=config)
    else:
        script = _FIRST_MOTION_STEP.format(scenario=config, cranes=cranes)
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        runs = [
            subprocess.run([sys.executable, "-c", script], env=env, check=True,
                           capture_output=True, text=True)  # fmt: skip
            for _ in range(2)
        ]
    first, second = (float(r.stdout.split()[-1]) for r in runs)
    return first, second
