"""The native PufferLib 3 envs: PufferLib's checks, equality with the vector envs, its trainer.

Skipped unless PufferLib 3 is installed (``tools/test_pufferlib.sh`` makes .venv-pufferlib,
installs it and runs this file). The trainer runs in a subprocess: importing
``pufferlib.pufferl`` installs a SIGINT handler and rich's traceback hook in the process.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

puffer_env = pytest.importorskip(
    "multicrane.integrations.pufferlib_env", reason="needs PufferLib 3 (tools/test_pufferlib.sh)"
)
import pufferlib  # noqa: E402  (imported above, from a temporary directory)
import pufferlib.vector  # noqa: E402

from multicrane.vector.motion_vector_env import MotionVectorEnv  # noqa: E402
from multicrane.vector.paper_vector_env import PaperVectorEnv  # noqa: E402


def legal_actions(rng: np.random.Generator, masks: np.ndarray) -> np.ndarray:
    """One legal action per row of ``masks`` ``[..., A]``, drawn uniformly."""
    flat = masks.reshape(-1, masks.shape[-1])
    return np.array([rng.choice(np.flatnonzero(row)) for row in flat]).reshape(masks.shape[:-1])


def assert_same_step(env, outputs, reference) -> None:
    """The PufferLib env's step outputs equal the vector env's, one agent per row."""
    obs, rewards, terminals, truncations, _ = outputs
    ref_obs, ref_rewards, ref_terminated, ref_truncated, _ = reference
    np.testing.assert_array_equal(obs, ref_obs.reshape(env.num_agents, -1))
    np.testing.assert_array_equal(rewards, ref_rewards.reshape(-1).astype(np.float32))
    np.testing.assert_array_equal(terminals, ref_terminated.reshape(-1))
    np.testing.assert_array_equal(truncations, ref_truncated.reshape(-1))
    assert env.masks.all()


def test_paper_env_is_native_and_matches_the_vector_env():
    env = pufferlib.vector.make(puffer_env.PaperPufferEnv, env_kwargs={"num_envs": 4})
    assert isinstance(env, pufferlib.PufferEnv) and not env.emulated
    reference = PaperVectorEnv(4, mask_blocked_moves=True)
    env = puffer_env.PaperPufferEnv(4, mask_blocked_moves=True, seed=7)
    obs, infos = env.reset()
    ref_obs, _ = reference.reset(seed=7)
    assert infos == [] and env.num_agents == 4 and obs.shape == (4, 1350)
    np.testing.assert_array_equal(obs, ref_obs)
    rng = np.random.default_rng(0)
    ended = 0
    for _ in range(250):  # E1S1 episodes last at most 100 steps: autoresets included
        np.testing.assert_array_equal(env.action_masks(), reference.action_masks())
        actions = legal_actions(rng, reference.action_masks()).astype(np.int32)
        outputs = env.step(actions)
        assert_same_step(env, outputs, reference.step(actions))
        for log in outputs[4]:
            ended += log["episodes"]
            assert set(log) == {"episode_return", "episode_length", "is_success", "episodes"}
    assert ended >= 8
    # Made without PufferLib's buffers, it hands PufferLib the vector env's own arrays.
    assert np.shares_memory(env.observations, env.vector.buffers.obs)
    assert np.shares_memory(env.terminals, env.vector.buffers.terminated)


def test_motion_env_matches_the_vector_env_crane_by_crane():
    env = puffer_env.MotionPufferEnv(2, "e2s2", n_cranes=2, seed=3)
    reference = MotionVectorEnv(2, "e2s2", n_cranes=2)
    obs, _ = env.reset()
    ref_obs, _ = reference.reset(seed=3)
    assert env.num_agents == 4 and env.action_masks().shape == (4, reference.n_actions)
    np.testing.assert_array_equal(obs, ref_obs.reshape(4, -1))
    rng = np.random.default_rng(1)
    for _ in range(120):
        masks = reference.action_masks()
        np.testing.assert_array_equal(env.action_masks(), masks.reshape(4, -1))
        actions = legal_actions(rng, masks)
        outputs = env.step(actions.reshape(-1).astype(np.int32))
        assert_same_step(env, outputs, reference.step(actions))


def test_serial_backend_copies_into_pufferlib_buffers():
    """PufferLib's Serial backend gives each env its slice of its buffers and seeds env i
    with seed + i: each slice matches a vector env with that seed."""
    vecenv = pufferlib.vector.make(
        puffer_env.PaperPufferEnv, env_kwargs={"num_envs": 3}, num_envs=2,
        backend=pufferlib.vector.Serial,
    )  # fmt: skip
    references = [PaperVectorEnv(3), PaperVectorEnv(3)]
    vecenv.async_reset(11)
    obs = vecenv.recv()[0]
    for i, reference in enumerate(references):
        np.testing.assert_array_equal(obs[3 * i : 3 * i + 3], reference.reset(seed=11 + i)[0])
    rng = np.random.default_rng(2)
    for _ in range(120):
        actions = rng.integers(6, size=6).astype(np.int32)
        vecenv.send(actions)
        obs, rewards, terminals, truncations, _, _, masks = vecenv.recv()
        for i, reference in enumerate(references):
            rows = slice(3 * i, 3 * i + 3)
            ref = reference.step(actions[rows])
            np.testing.assert_array_equal(obs[rows], ref[0])
            np.testing.assert_array_equal(rewards[rows], ref[1].astype(np.float32))
            np.testing.assert_array_equal(terminals[rows], ref[2])
            np.testing.assert_array_equal(truncations[rows], ref[3])
        assert masks.all()
    vecenv.close()


TRAIN = """
import ast, configparser, os, sys
import torch
torch.set_num_threads(1)
from multicrane.integrations.pufferlib_env import PaperPufferEnv
import pufferlib, pufferlib.models, pufferlib.pufferl, pufferlib.vector

ini = configparser.ConfigParser()
ini.read(os.path.join(os.path.dirname(pufferlib.__file__), "config", "default.ini"))
config = {key: ast.literal_eval(v) if v[:1].isdigit() or v in ("True", "False") else v
          for key, v in ini["train"].items()}
config.update(device="cpu", optimizer="adam", learning_rate=3e-4, batch_size=512,
              bptt_horizon=32, minibatch_size=512, max_minibatch_size=512,
              total_timesteps=1024, use_rnn=False, data_dir=sys.argv[1], compile=False,
              checkpoint_interval=1000, env="multicrane-paper")
vecenv = pufferlib.vector.make(PaperPufferEnv, env_kwargs={"num_envs": 16})
trainer = pufferlib.pufferl.PuffeRL(config, vecenv, pufferlib.models.Default(vecenv, 32))
while trainer.global_step < config["total_timesteps"]:
    trainer.evaluate()
    trainer.train()
print("RESULT", trainer.global_step, trainer.epoch, file=sys.stderr)
trainer.close()
"""


def test_pufferlib_trainer_runs_the_native_env(tmp_path):
    """Two epochs of PufferLib's own PPO trainer (CPU) on 16 copies of E1S1."""
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(TRAIN), str(tmp_path / "runs")],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    assert "RESULT 1024 2" in done.stderr
    assert list((tmp_path / "runs").glob("*.pt"))
