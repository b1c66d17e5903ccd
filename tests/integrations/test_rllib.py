"""RLlib (new API stack): the adapter, the registered environments, ``train --backend rllib``.

The adapter tests import RLlib but start no Ray (a few seconds). The training test (markers
``ray`` and ``long``: it runs with ``-m long``) starts a Ray cluster on 127.0.0.1 (a head
node with two CPUs) and runs ``multicrane train --backend rllib --address ...`` in a
subprocess against it: two small iterations of the shared masked PPO policy on e2s2 with two
env runners (two worker processes), then reloads the checkpoint here. About 15-20 s on a
quiet 2-core machine (66 s measured under a load average of 5-10). All skip when the
``rllib`` extra is not installed.
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

from multicrane.cli import main
from multicrane.episodes.random_actions import random_legal_actions

ROOT = Path(__file__).resolve().parents[2]

rllib = pytest.importorskip(
    "multicrane.integrations.rllib",
    reason="RLlib not installed (pip install 'multicrane[rllib]')",
    exc_type=ImportError,
)


@pytest.fixture(autouse=True)
def one_thread():
    import torch

    torch.set_num_threads(1)


def legal(obs, rng):
    return random_legal_actions({a: o["action_mask"] for a, o in obs.items()}, rng)


def test_adapter_gives_rllib_keys_and_one_episode_end():
    env = rllib.CraneMultiAgentEnv({"scenario": "e2s2", "n_cranes": 2})
    obs, infos = env.reset(seed=3)
    assert set(obs) == set(env.possible_agents) == {"crane_0", "crane_1"}
    for agent, o in obs.items():
        assert set(o) == {"observations", "action_mask"}
        assert o["action_mask"].dtype == np.float32
        assert env.observation_spaces[agent].contains(o)
    rng = np.random.default_rng(0)
    total, team, steps = 0.0, 0.0, 0
    while True:
        obs, rewards, terms, truncs, infos = env.step(legal(obs, rng))
        total += sum(rewards.values())
        team += env.env.total_reward - team
        steps += 1
        if terms["__all__"] or truncs["__all__"]:
            break
        assert env.agents == env.possible_agents
    assert not (terms["__all__"] and truncs["__all__"])
    assert env.agents == []
    assert math.isclose(total, env.env.total_reward, abs_tol=1e-6)  # split: sum = team
    assert steps <= env.env.step_limit


def test_adapter_refuses_the_flat_observation():
    with pytest.raises(ValueError, match="obs_format='flat'"):
        rllib.CraneMultiAgentEnv({"scenario": "e2s2", "obs_format": "flat"})


def test_registered_names_build_their_environments():
    from ray.tune.registry import ENV_CREATOR, _global_registry

    names = rllib.register_envs()
    assert {"multicrane", "multicrane/e3s2-v0", "multicrane/PaperAssembly-E2S2-v0"} <= set(names)
    env = _global_registry.get(ENV_CREATOR, "multicrane/e3s2-v0")({"n_cranes": 2})
    assert env.possible_agents == ["crane_0", "crane_1"]
    paper = _global_registry.get(ENV_CREATOR, "multicrane/PaperAssembly-E2S2-v0")({})
    assert paper.unwrapped.config == "E2S2"


def test_ppo_config_fails_early_on_a_bad_scenario():
    from multicrane import ScenarioError

    with pytest.raises(ScenarioError):
        rllib.ppo_config("no-such-scenario")


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--paper", "E2S2"], "use --scenario"),
        (["--scenario", "e2s2", "--algo", "ppo"], "--algo is an option of the sb3 backend"),
        (["--scenario", "e2s2", "--reward-scale", "site"],
         "--reward-scale is an option of the sb3 backend"),
        (["--scenario", "e2s2", "--set", "lr"], "expected KEY=VALUE"),
    ],
)
def test_cli_rllib_backend_refuses_options_it_does_not_take(argv, message, capsys):
    assert main(["train", "--backend", "rllib", *argv]) == 2
    assert message in capsys.readouterr().err


@pytest.mark.ray
@pytest.mark.long
def test_train_command_on_a_local_cluster_and_the_checkpoint_reloads(tmp_path, monkeypatch):
    from ray._private import ray_constants
    from ray.cluster_utils import Cluster

    # Every Ray process on the loopback address: Ray otherwise rewrites 127.0.0.1 to the
    # machine's outward address when a driver joins (the variable is read at import, so the
    # constant is set for this process and the variable for the processes Ray starts).
    monkeypatch.setenv("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
    monkeypatch.setattr(ray_constants, "ENABLE_RAY_CLUSTER", False)
    monkeypatch.setenv("RAY_AUTH_MODE", "disabled")
    cluster = Cluster(
        initialize_head=True,
        head_node_args={"num_cpus": 2, "node_ip_address": "127.0.0.1", "include_dashboard": False},
    )
    out = tmp_path / "run"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), *sys.path])}
    try:
        assert cluster.address.startswith("127.0.0.1:")
        # The command in its own process, as a user runs it (a driver's Ray state does not
        # survive a second Ray session in one process reliably).
        done = subprocess.run([
            sys.executable, "-m", "multicrane", "train", "--backend", "rllib",
            "--scenario", "e2s2", "--cranes", "2", "--address", cluster.address, "--envs", "2",
            "--steps", "400", "--out", str(out), "--eval-episodes", "2",
            "--set", "train_batch_size_per_learner=200", "--set", "minibatch_size=100",
            "--set", "num_epochs=1",
        ], env=env, capture_output=True, text=True, timeout=600)  # fmt: skip
    finally:
        cluster.shutdown()
    assert done.returncode == 0, done.stderr[-3000:]
    assert "final evaluation" in done.stdout
    result = json.loads((out / "result.json").read_text())
    assert result["iterations"] == 2 and result["steps"] >= 400
    assert all(math.isfinite(c["return_mean"]) for c in result["curve"])
    assert math.isfinite(result["final"]["return_mean"])
    # The checkpoint reloads without Ray, and the module picks legal actions only.
    import multicrane

    policy = rllib.ModulePolicy(rllib.load_module(result["checkpoint"]))
    env = multicrane.parallel_env("e2s2", n_cranes=2)
    obs, _ = env.reset(seed=1)
    rng = np.random.default_rng(1)
    for _ in range(30):
        actions = policy(obs)
        for agent, action in actions.items():
            assert obs[agent]["action_mask"][action], (agent, action)
        obs, *_ = env.step(legal(obs, rng))  # random moves visit more states
        if not env.agents:
            break
