"""Train one shared PPO policy with RLlib, on a Ray cluster or a local one: checkpoint, result.

    from multicrane.integrations.rllib_train import train_rllib
    result = train_rllib("e3s2", n_cranes=2, out=Path("runs/rllib-e3s2"), steps=20_000)

``address=None`` starts a new local Ray instance (``num_cpus``: one per env runner plus one
for the driver and learner; never one that is already running) and shuts it down at the
end; ``"auto"`` joins the cluster this machine belongs to (``ray start --head`` on one
node, ``ray start --address HEAD:6379`` on the others, every node with
``pip install "multicrane[rllib]"``); ``"ray://host:10001"`` connects a Ray client. A
Ray instance the caller already started is used and left running.

Training stops after the first iteration that reaches ``steps`` sampled environment steps
(one step is one joint step of all cranes). The run directory ``out`` then holds
``checkpoint/`` (``Algorithm.save_to_path``; ``multicrane.integrations.rllib.load_module``
reads the shared module back) and ``result.json``: iterations, steps, seconds, RLlib's
episode return mean per iteration, and a greedy evaluation of the reloaded module on
``eval_episodes`` fixed seeds (``multicrane.episodes.rollout.evaluate``).
"""

from __future__ import annotations

import math
import os
import time
from pathlib import Path
from typing import Any

from multicrane.files import write_json_atomic


def _init_ray(ray, address: str | None, num_cpus: int) -> bool:
    """Start or join Ray unless it is running; True when this call started it."""
    if ray.is_initialized():
        return False
    os.environ.setdefault("RAY_AUTH_MODE", "disabled")  # no token file for a local run
    options: dict[str, Any] = {
        "include_dashboard": False,
        "runtime_env": {"env_vars": {"OMP_NUM_THREADS": "1"}},
    }
    if address:
        ray.init(address=address, **options)
    else:
        ray.init(address="local", num_cpus=num_cpus, **options)  # never someone else's
    return True


def _finite(x) -> float | None:
    return None if x is None or not math.isfinite(float(x)) else float(x)


def train_rllib(
    scenario: str,
    n_cranes: int | None,
    out: Path,
    *,
    steps: int = 20_000,
    seed: int = 0,
    address: str | None = None,
    num_env_runners: int = 2,
    env_options: dict[str, Any] | None = None,
    training: dict[str, Any] | None = None,
    eval_episodes: int = 5,
    log=print,
) -> dict[str, Any]:
    """Train, save the checkpoint and ``result.json`` in ``out``; the result (module doc)."""
    import ray
    import torch

    from multicrane.episodes.rollout import evaluate
    from multicrane.integrations import rllib as mc_rllib

    if steps < 1:
        raise ValueError(f"steps={steps}: expected at least 1")
    if num_env_runners < 0:
        raise ValueError(f"num_env_runners={num_env_runners}: expected 0 or more")
    torch.set_num_threads(1)
    env = multicrane_env(scenario, n_cranes, env_options)  # a bad scenario fails before Ray
    out.mkdir(parents=True, exist_ok=True)
    # Ray first, then the config: nothing may touch Ray (e.g. Ray Tune's registry) before
    # this process is connected, or Ray auto-connects to whatever cluster it finds.
    own = _init_ray(ray, address, num_cpus=num_env_runners + 1)
    try:
        config = mc_rllib.ppo_config(
            scenario, n_cranes, env_options=env_options, num_env_runners=num_env_runners,
            seed=seed, training=training,
        )  # fmt: skip
        algo = config.build_algo()
        start = time.perf_counter()
        curve: list[dict[str, Any]] = []
        sampled = 0
        while sampled < steps:
            r = algo.train()
            sampled = int(r["env_runners"].get("num_env_steps_sampled_lifetime", 0))
            ret = _finite(r["env_runners"].get("episode_return_mean"))
            curve.append({"iteration": len(curve) + 1, "steps": sampled, "return_mean": ret})
            log(f"iteration {len(curve)}: {sampled} steps, episode return mean {ret}")
        seconds = time.perf_counter() - start
        checkpoint = out / "checkpoint"
        algo.save_to_path(str(checkpoint.resolve()))
        algo.stop()
    finally:
        if own:
            ray.shutdown()
    module = mc_rllib.load_module(str(checkpoint))
    policy = mc_rllib.ModulePolicy(module)
    _, final = evaluate(env, lambda env, seed: policy, seeds=range(eval_episodes))
    result = {
        "backend": "rllib",
        "scenario": scenario,
        "n_cranes": env.sim.n_cranes,
        "seed": seed,
        "address": address,
        "num_env_runners": num_env_runners,
        "iterations": len(curve),
        "steps": sampled,
        "train_seconds": seconds,
        "steps_per_second": sampled / seconds if seconds > 0 else None,
        "curve": curve,
        "final": final,
        "checkpoint": str(checkpoint),
    }
    write_json_atomic(out / "result.json", result)
    return result


def multicrane_env(scenario: str, n_cranes: int | None, env_options: dict[str, Any] | None):
    """The evaluation environment: the training one's options, team reward."""
    import multicrane

    options = {k: v for k, v in dict(env_options or {}).items() if k != "reward_mode"}
    return multicrane.parallel_env(scenario, n_cranes=n_cranes, **options)
