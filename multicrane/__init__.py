"""multicrane: planning how cranes assemble prefabricated buildings.

    import multicrane
    env = multicrane.parallel_env("e3s2", n_cranes=2)   # PettingZoo ParallelEnv
    aec = multicrane.env("frame2-3c")                   # the AEC form
    multicrane.scenario_names()                         # the shipped scenarios

Importing this package loads numpy, gymnasium and pettingzoo only.
"""

from __future__ import annotations

from pathlib import Path

from multicrane.core.codes import Event, EventType, Kind, Move, Status
from multicrane.core.schema import Scenario, ScenarioError
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.envs.joint_env import JOINT_ENV_ID
from multicrane.envs.paper_env import PAPER_CONFIGS, PaperAssemblyEnv, paper_env_id
from multicrane.scenario.catalog import scenario_names
from multicrane.scenario.loader import load_scenario

__version__ = "0.1.0"


def parallel_env(scenario: str | Path | Scenario = "e2s2", n_cranes: int | None = None, **options):
    """The multi-agent environment (PettingZoo ``ParallelEnv``); see ``MultiCraneEnv``."""
    return MultiCraneEnv(scenario, n_cranes=n_cranes, **options)


def env(scenario: str | Path | Scenario = "e2s2", n_cranes: int | None = None, **options):
    """The AEC form of :func:`parallel_env` (through PettingZoo's ``parallel_to_aec``)."""
    from pettingzoo.utils.conversions import parallel_to_aec

    return parallel_to_aec(parallel_env(scenario, n_cranes=n_cranes, **options))


# PettingZoo's convention names the unwrapped AEC environment ``raw_env``; ``env`` adds no
# wrappers here, so the two are the same.
raw_env = env


def _register() -> None:
    """Register every shipped scenario with PettingZoo (``pettingzoo.make("parallel",
    "multicrane/e3s2-v0")``, and ``"aec"``) and the 16 paper configurations with Gymnasium
    (``gymnasium.make("multicrane/PaperAssembly-E1S1-v0")``), and every crane of any scenario as
    one Gymnasium agent (``gymnasium.make("multicrane/Joint-v0", scenario="hall-4c")``)."""
    import gymnasium
    from pettingzoo.env_registry import register

    for name in scenario_names():
        env_id = f"multicrane/{name}-v0"
        register(
            "parallel", env_id, entry_point="multicrane:parallel_env", kwargs={"scenario": name}
        )
        register("aec", env_id, entry_point="multicrane:env", kwargs={"scenario": name})
    for config in PAPER_CONFIGS:
        env_id = paper_env_id(config)
        if env_id not in gymnasium.registry:
            # No OrderEnforcing / PassiveEnvChecker wrappers (the env checks its own call
            # order and actions): ``gymnasium.make(id).action_masks()`` then works as it is,
            # for MaskablePPO and other callers, without ``.unwrapped``.
            gymnasium.register(
                env_id,
                entry_point="multicrane.envs.paper_env:PaperAssemblyEnv",
                # gymnasium.make_vec(env_id, num_envs=B): B copies in compiled kernels
                # (multicrane.vector, docs/vector.md; numba is imported only then).
                vector_entry_point="multicrane.vector.paper_vector_env:PaperVectorEnv",
                kwargs={"config": config},
                order_enforce=False,
                disable_env_checker=True,
            )
    if JOINT_ENV_ID not in gymnasium.registry:
        gymnasium.register(
            JOINT_ENV_ID,
            entry_point="multicrane.envs.joint_env:JointCraneEnv",
            order_enforce=False,
            disable_env_checker=True,
        )


_register()

__all__ = [
    "PAPER_CONFIGS",
    "PaperAssemblyEnv",
    "paper_env_id",
    "Event",
    "EventType",
    "Kind",
    "Move",
    "MultiCraneEnv",
    "Scenario",
    "ScenarioError",
    "Status",
    "env",
    "load_scenario",
    "parallel_env",
    "raw_env",
    "scenario_names",
]
