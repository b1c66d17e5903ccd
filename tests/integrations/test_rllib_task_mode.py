"""Task-level decisions through RLlib: the adapter, and ``train --backend rllib --decisions task``.

The training test (markers ``ray`` and ``long``) runs the command in its own process on a
local Ray instance (no cluster: tests/integrations/test_rllib.py covers ``--address``), one
small iteration, then
reloads the checkpoint here and plays task mode with it. About 15 s on a quiet 2-core
machine, 43 s measured under a load average of 5. All skip without the ``rllib`` extra.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import multicrane
from multicrane.episodes.random_actions import random_legal_actions

ROOT = Path(__file__).resolve().parents[2]

rllib = pytest.importorskip(
    "multicrane.integrations.rllib",
    reason="RLlib not installed (pip install 'multicrane[rllib]')",
    exc_type=ImportError,
)


def test_adapter_in_task_mode_has_the_task_action_space_and_ends_once():
    env = rllib.CraneMultiAgentEnv({"scenario": "e2s2", "n_cranes": 2, "decisions": "task"})
    plain = multicrane.parallel_env("e2s2", n_cranes=2, decisions="task")
    obs, _ = env.reset(seed=2)
    plain_obs, _ = plain.reset(seed=2)
    for agent, o in obs.items():
        assert env.action_spaces[agent] == plain.action_space(agent)
        np.testing.assert_array_equal(o["observations"], plain_obs[agent]["observation"])
        np.testing.assert_array_equal(o["action_mask"], plain_obs[agent]["action_mask"])
    rng = np.random.default_rng(0)
    for _ in range(plain.step_limit):
        actions = random_legal_actions({a: o["action_mask"] for a, o in obs.items()}, rng)
        obs, _, terms, truncs, _ = env.step(actions)
        if terms["__all__"] or truncs["__all__"]:
            break
    assert (terms["__all__"] or truncs["__all__"]) and env.agents == []


@pytest.mark.ray
@pytest.mark.long
def test_train_command_in_task_mode_and_the_module_picks_legal_tasks(tmp_path):
    out = tmp_path / "run"
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), *sys.path])
    done = subprocess.run([
        sys.executable, "-m", "multicrane", "train", "--backend", "rllib",
        "--scenario", "e2s2", "--cranes", "2", "--decisions", "task", "--envs", "0",
        "--steps", "100", "--out", str(out), "--eval-episodes", "1",
        "--set", "train_batch_size_per_learner=100", "--set", "minibatch_size=50",
        "--set", "num_epochs=1",
    ], env=env, capture_output=True, text=True, timeout=600)  # fmt: skip
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads((out / "result.json").read_text())
    assert result["iterations"] == 1 and result["steps"] >= 100
    assert math.isfinite(result["final"]["return_mean"])
    policy = rllib.ModulePolicy(rllib.load_module(result["checkpoint"]))
    task_env = multicrane.parallel_env("e2s2", n_cranes=2, decisions="task")
    obs, _ = task_env.reset(seed=1)
    n_actions = task_env.action_space("crane_0").n
    for _ in range(50):
        actions = policy(obs)
        for agent, action in actions.items():
            assert 0 <= action < n_actions and obs[agent]["action_mask"][action], (agent, action)
        obs, *_ = task_env.step(actions)
        if not task_env.agents:
            break
