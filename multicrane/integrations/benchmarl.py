"""BenchMARL tasks: any scenario as a BenchMARL task, for its MAPPO, IPPO, QMIX, ... experiments.

    from benchmarl.algorithms import MappoConfig
    from benchmarl.experiment import Experiment, ExperimentConfig
    from benchmarl.models.mlp import MlpConfig
    from multicrane.integrations.benchmarl import MulticraneTask

    task = MulticraneTask.E3S2.get_task({"n_cranes": 2, "max_cycles": 100})
    Experiment(task=task, algorithm_config=MappoConfig.get_from_yaml(),
               model_config=MlpConfig.get_from_yaml(),
               critic_model_config=MlpConfig.get_from_yaml(),
               seed=0, config=ExperimentConfig.get_from_yaml()).run()

Needs the ``benchmarl`` extra (``pip install "multicrane[benchmarl]"``: BenchMARL 1.5.2,
TorchRL 0.11), in a venv without the ``torchrl`` extra (TorchRL 0.14): the two conflict.

- ``MulticraneTask``: BenchMARL's task enum, one member per shipped scenario (``E3S2``,
  ``FRAME2_3C``, ...; the name upper-cased, ``-`` as ``_``). ``get_task(config)`` and
  ``get_from_yaml()`` (no path: the defaults below) give a ``MulticraneClass``.
- ``register()``: puts every member in BenchMARL's task registry and Hydra's config store as
  ``multicrane/<scenario>``, for BenchMARL's Hydra command line
  (``python -m multicrane.integrations.benchmarl_run algorithm=mappo task=multicrane/e3s2``).
- ``MulticraneClass``: the task. ``get_env_fun`` returns TorchRL's own ``PettingZooWrapper``
  around ``multicrane.parallel_env`` (categorical actions, the action mask read from the
  observation, the global ``state()`` for centralised critics), no custom wrapper; the specs
  come from BenchMARL's ``PettingZooClass``. The cranes form one group, ``"crane"``.

Config keys (all optional): ``scenario`` (default: the member's; a shipped name or a TOML
path), ``n_cranes`` (None: the scenario's), ``decisions`` (``"motion"`` or ``"task"``),
``max_cycles`` (None: the scenario's step limit; also BenchMARL's evaluation length), and
the other ``MultiCraneEnv`` keywords ``max_steps``, ``reward``, ``reward_mode``,
``task_patience``, ``task_site_planes``, ``auto``, ``strict``. The observation format, the
infos and rendering are fixed by the task (what TorchRL batches); any other key is refused.
BenchMARL names its run folders and results after the member (``mappo_e3s2_mlp__...``),
also when ``scenario`` names another site.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from typing import Any

import multicrane
from multicrane.scenario.catalog import scenario_names

try:
    from benchmarl.environments import PettingZooClass, Task
    from torchrl.envs import EnvBase
    from torchrl.envs.libs.pettingzoo import PettingZooWrapper
except ImportError as exc:  # pragma: no cover - depends on the installed extras
    raise ImportError(
        "multicrane.integrations.benchmarl needs BenchMARL: pip install 'multicrane[benchmarl]' "
        "in a venv without the 'torchrl' extra (BenchMARL 1.5 needs torchrl<0.12; "
        f"tools/test_benchmarl.sh makes one) (missing: {exc.name})"
    ) from exc

ENV_NAME = "multicrane"
GROUP = "crane"
DEFAULTS: dict[str, Any] = {"n_cranes": None, "decisions": "motion", "max_cycles": None}
# The MultiCraneEnv keywords a task config may set; the rest are fixed by the task.
ENV_KEYS = (
    "scenario",
    "n_cranes",
    "decisions",
    "max_cycles",
    "max_steps",
    "reward",
    "reward_mode",
    "task_patience",
    "task_site_planes",
    "auto",
    "strict",
)


def member_name(scenario: str) -> str:
    """The ``MulticraneTask`` member of a shipped scenario: ``"frame2-3c"`` -> ``"FRAME2_3C"``."""
    return scenario.upper().replace("-", "_")


def env_options(config: dict[str, Any]) -> dict[str, Any]:
    """The ``multicrane.parallel_env`` keywords of a task config; unknown keys are refused."""
    unknown = sorted(set(config) - set(ENV_KEYS))
    if unknown:
        raise ValueError(
            f"multicrane BenchMARL task config: unknown key(s) {unknown}; "
            f"allowed: {', '.join(ENV_KEYS)}"
        )
    return {key: value for key, value in config.items() if value is not None}


class MulticraneClass(PettingZooClass):
    """One multicrane scenario as a BenchMARL task (discrete, masked actions, global state)."""

    def __init__(self, name: str, config: dict[str, Any] | None):
        super().__init__(name=name, config=config)
        env_options(self.config)  # a bad key fails here, before BenchMARL builds anything

    def _scenario(self) -> Any:
        return self.config.get("scenario") or _SCENARIOS[self.name]

    def make_env(self) -> multicrane.MultiCraneEnv:
        """The PettingZoo environment this task wraps (numeric infos, Dict observation)."""
        options = env_options(self.config)
        options["scenario"] = self._scenario()
        return multicrane.parallel_env(**options)

    def get_env_fun(
        self, num_envs: int, continuous_actions: bool, seed: int | None, device: Any
    ) -> Callable[[], EnvBase]:
        if continuous_actions:
            raise ValueError("multicrane tasks have discrete actions only (continuous asked)")
        task = copy.deepcopy(self)
        return lambda: _wrap(task.make_env(), device=device, seed=seed)

    def supports_continuous_actions(self) -> bool:
        return False

    def supports_discrete_actions(self) -> bool:
        return True

    def has_state(self) -> bool:
        return True

    def has_render(self, env: EnvBase) -> bool:
        return False  # the environment renders text or to the rerun viewer, not rgb arrays

    def max_steps(self, env: EnvBase) -> int:
        cycles = self.config.get("max_cycles")
        if cycles is not None:
            return int(cycles)
        return int(self.make_env().step_limit)

    @staticmethod
    def env_name() -> str:
        return ENV_NAME


def _wrap(env: multicrane.MultiCraneEnv, device: Any, seed: int | None) -> EnvBase:
    """TorchRL's own PettingZooWrapper around the environment, the cranes in one group."""
    return PettingZooWrapper(
        env=env,
        categorical_actions=True,
        use_mask=True,
        return_state=True,
        group_map={GROUP: list(env.possible_agents)},
        device=device,
        seed=seed,
    )


_SCENARIOS = {member_name(name): name for name in scenario_names()}


class _MulticraneTaskBase(Task):
    """The behaviour of ``MulticraneTask`` (its members are made from the shipped scenarios)."""

    @staticmethod
    def associated_class() -> type[MulticraneClass]:
        return MulticraneClass

    def get_from_yaml(self, path: str | None = None) -> MulticraneClass:
        """The task with the defaults (``max_cycles`` None: the scenario's step limit), or
        with the config of the YAML file at ``path``."""
        if path is None:
            return self.get_task(config=dict(DEFAULTS))
        return super().get_from_yaml(path)


MulticraneTask = _MulticraneTaskBase("MulticraneTask", list(_SCENARIOS), module=__name__)
MulticraneTask.__doc__ = "BenchMARL's task enum for multicrane: one member per shipped scenario."


def register() -> list[str]:
    """Every ``MulticraneTask`` member in BenchMARL's task registry and in Hydra's config
    store as ``multicrane/<scenario>`` (its config: the defaults); returns the names. Safe
    to call again."""
    from benchmarl.environments import task_config_registry
    from hydra.core.config_store import ConfigStore

    store = ConfigStore.instance()
    names = []
    for member in MulticraneTask:
        name = f"{ENV_NAME}/{member.name.lower()}"
        task_config_registry[name] = member
        store.store(group=f"task/{ENV_NAME}", name=member.name.lower(), node=dict(DEFAULTS))
        names.append(name)
    return names
