"""BenchMARL: the multicrane task under BenchMARL's own Experiment (MAPPO, IPPO, QMIX).

Runs only where BenchMARL is installed (its own venv: ``tools/test_benchmarl.sh``, about a
minute); skipped in the default suite, whose venv has TorchRL 0.14 (BenchMARL 1.5 needs 0.11).
"""

from __future__ import annotations

import csv
import json
import math
import os
import runpy
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("benchmarl", exc_type=ImportError)

import torch  # noqa: E402
from benchmarl.algorithms import IppoConfig, QmixConfig  # noqa: E402
from benchmarl.experiment import Experiment, ExperimentConfig  # noqa: E402
from benchmarl.models.mlp import MlpConfig  # noqa: E402

import multicrane  # noqa: E402
from multicrane.integrations.benchmarl import (  # noqa: E402
    ENV_KEYS,
    MulticraneClass,
    MulticraneTask,
    member_name,
    register,
)

pytestmark = pytest.mark.benchmarl
ROOT = Path(__file__).resolve().parents[2]
RECIPE = ROOT / "docs" / "recipes" / "benchmarl_mappo.py"
# The Hydra command of docs/ecosystem.md; the test adds a small run's experiment keys.
HYDRA = "python -m multicrane.integrations.benchmarl_run algorithm=mappo task=multicrane/e3s2"
torch.set_num_threads(1)


def _scalars(folder: Path, prefix: str) -> dict[str, list[float]]:
    """BenchMARL's CSV logger: one file per scalar, rows of (step, value)."""
    out = {}
    for path in sorted(folder.glob(f"*/scalars/{prefix}*.csv")):
        with path.open() as f:
            out[path.stem] = [float(row[1]) for row in csv.reader(f)]
    return out


def _assert_masks_respected(experiment: Experiment) -> None:
    """A rollout of the trained policy picks only actions the environment's mask allows."""
    with torch.no_grad():
        td = experiment.test_env.rollout(
            experiment.max_steps, policy=experiment.policy, break_when_any_done=True
        )
    actions = td["crane", "action"]
    masks = td["crane", "action_mask"]
    assert actions.shape == masks.shape[:-1] and actions.numel() > 0
    assert masks.gather(-1, actions.unsqueeze(-1)).all()


@pytest.fixture(scope="module")
def mappo_recipe(tmp_path_factory):
    """The docs/ecosystem.md recipe, run once as it is (in a scratch working directory)."""
    here = os.getcwd()
    os.chdir(tmp_path_factory.mktemp("benchmarl"))
    try:
        return runpy.run_path(str(RECIPE), run_name="__main__")
    finally:
        os.chdir(here)


def test_recipe_trains_mappo_and_saves_a_checkpoint(mappo_recipe):
    experiment = mappo_recipe["experiment"]
    folder = Path(experiment.folder_name)
    assert experiment.n_iters_performed == 2 and experiment.total_frames == 200
    assert list((folder / "checkpoints").glob("checkpoint_*.pt"))
    losses = _scalars(folder, "train_crane_loss")
    assert {"train_crane_loss_objective", "train_crane_loss_critic"} <= set(losses)
    assert all(math.isfinite(v) for values in losses.values() for v in values)
    (result,) = folder.glob("*.json")
    returns = json.loads(result.read_text())["multicrane"]["e3s2"]["mappo"]["seed_0"]
    assert all(math.isfinite(r) for r in returns["absolute_metrics"]["return"])


def test_mappo_policy_respects_the_action_masks(mappo_recipe):
    _assert_masks_respected(mappo_recipe["experiment"])


def _small_config(folder: Path) -> ExperimentConfig:
    config = ExperimentConfig.get_from_yaml()
    config.sampling_device = config.train_device = config.buffer_device = "cpu"
    config.max_n_iters, config.max_n_frames = 1, None
    config.on_policy_collected_frames_per_batch = config.off_policy_collected_frames_per_batch = 60
    config.on_policy_n_envs_per_worker = config.off_policy_n_envs_per_worker = 2
    config.on_policy_minibatch_size, config.on_policy_n_minibatch_iters = 30, 1
    config.off_policy_train_batch_size, config.off_policy_n_optimizer_steps = 16, 2
    config.off_policy_init_random_frames = 0
    # QMIX's default buffer (10^6 frames of every crane's observation and the global state)
    # would need tens of GB for this observation size.
    config.off_policy_memory_size = 500
    config.evaluation = False
    config.loggers = ["csv"]
    config.save_folder = str(folder)
    return config


@pytest.mark.parametrize(
    ("algorithm", "decisions"),
    [(IppoConfig, "task"), (QmixConfig, "motion")],
    ids=["ippo-task", "qmix-motion"],
)
def test_ippo_and_qmix_train_on_both_decision_levels(algorithm, decisions, tmp_path):
    task = MulticraneTask.E2S2.get_task({"n_cranes": 2, "decisions": decisions, "max_cycles": 30})
    experiment = Experiment(
        task=task,
        algorithm_config=algorithm.get_from_yaml(),
        model_config=MlpConfig.get_from_yaml(),
        critic_model_config=MlpConfig.get_from_yaml(),
        seed=1,
        config=_small_config(tmp_path),
    )
    experiment.run()
    assert experiment.n_iters_performed == 1
    losses = _scalars(Path(experiment.folder_name), "train_crane_loss")
    assert losses and all(math.isfinite(v) for values in losses.values() for v in values)
    _assert_masks_respected(experiment)


def test_one_member_per_shipped_scenario_and_its_defaults():
    assert {m.name for m in MulticraneTask} == {member_name(n) for n in multicrane.scenario_names()}
    task = MulticraneTask.FRAME2_3C.get_from_yaml()
    assert isinstance(task, MulticraneClass) and task.name == "FRAME2_3C"
    assert task.make_env().scenario.name == "frame2-3c"
    assert task.supports_discrete_actions() and not task.supports_continuous_actions()


@pytest.mark.parametrize("decisions", ["motion", "task"])
def test_the_wrapped_env_matches_the_pettingzoo_env(decisions):
    config = {"n_cranes": 2, "decisions": decisions, "max_cycles": 7}
    task = MulticraneTask.E3S2.get_task(config)
    env = task.get_env_fun(num_envs=1, continuous_actions=False, seed=0, device="cpu")()
    plain = multicrane.parallel_env("e3s2", **config)
    n_actions = plain.action_space("crane_0").n
    assert task.group_map(env) == {"crane": ["crane_0", "crane_1"]}
    assert task.action_spec(env)["crane", "action"].space.n == n_actions
    assert task.action_mask_spec(env)["crane", "action_mask"].shape == (2, n_actions)
    assert task.state_spec(env)["state"].shape == plain.state_space.shape
    assert task.max_steps(env) == 7
    assert {"event_counts", "reward_term"} <= set(task.info_spec(env)["crane", "info"].keys())
    rollout = env.rollout(20)  # random legal actions; max_cycles truncates at 7
    assert rollout.batch_size == (7,) and rollout["next", "truncated"][-1].all()


def test_max_steps_defaults_to_the_scenario_step_limit():
    task = MulticraneTask.E3S2.get_task({"n_cranes": 2})
    assert task.max_steps(None) == multicrane.parallel_env("e3s2", n_cranes=2).step_limit


def test_a_scenario_file_path_in_the_config(tmp_path):
    from multicrane.scenario.catalog import resolve

    task = MulticraneTask.E2S2.get_task({"scenario": str(resolve("e3s2"))})
    assert task.make_env().scenario.name == "e3s2"


@pytest.mark.parametrize(
    ("config", "message"),
    [
        ({"obs_format": "flat"}, "unknown key(s) ['obs_format']"),
        ({"n_crane": 2}, "unknown key(s) ['n_crane']"),
    ],
)
def test_bad_config_keys_are_refused_by_name(config, message):
    with pytest.raises(ValueError) as err:
        MulticraneTask.E3S2.get_task(config)
    assert message in str(err.value) and ", ".join(ENV_KEYS) in str(err.value)


def test_continuous_actions_are_refused():
    task = MulticraneTask.E3S2.get_task({})
    with pytest.raises(ValueError, match="discrete actions only"):
        task.get_env_fun(num_envs=1, continuous_actions=True, seed=0, device="cpu")


def test_register_names_every_scenario_and_can_run_twice():
    names = register()
    assert names == register()
    assert set(names) == {f"multicrane/{n.lower()}" for n in _members()}


def _members() -> list[str]:
    return [m.name for m in MulticraneTask]


def test_the_hydra_command_of_the_docs_trains_and_saves_a_checkpoint(tmp_path):
    assert HYDRA in (ROOT / "docs" / "ecosystem.md").read_text()
    small = [
        "task.n_cranes=2",
        "task.max_cycles=30",
        "experiment.max_n_iters=1",
        "experiment.max_n_frames=null",
        "experiment.on_policy_collected_frames_per_batch=60",
        "experiment.on_policy_n_envs_per_worker=2",
        "experiment.on_policy_minibatch_size=30",
        "experiment.on_policy_n_minibatch_iters=1",
        "experiment.evaluation_episodes=1",
        "experiment.loggers=[csv]",
        "experiment.checkpoint_at_end=true",
        f"hydra.run.dir={tmp_path}",
    ]
    env = dict(os.environ, OMP_NUM_THREADS="1", PYTHONPATH=str(ROOT))
    done = subprocess.run(
        [sys.executable, *HYDRA.split()[1:], *small],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert list(tmp_path.glob("mappo_e3s2_mlp_*/checkpoints/checkpoint_*.pt"))


def test_same_seed_same_rollout_through_the_wrapper():
    task = MulticraneTask.E3S2.get_task({"n_cranes": 2, "max_cycles": 15})
    rollouts = []
    for _ in range(2):
        env = task.get_env_fun(num_envs=1, continuous_actions=False, seed=3, device="cpu")()
        torch.manual_seed(0)  # TorchRL's random actions
        rollouts.append(env.rollout(15))
    a, b = rollouts
    assert torch.equal(a["crane", "action"], b["crane", "action"])
    assert torch.equal(a["next", "state"], b["next", "state"])
    assert torch.equal(a["next", "crane", "reward"], b["next", "crane", "reward"])


def test_a_yaml_config_file_and_a_bad_value(tmp_path):
    path = tmp_path / "task.yaml"
    path.write_text("n_cranes: 2\ndecisions: task\nmax_cycles: 12\n")
    task = MulticraneTask.E3S2.get_from_yaml(str(path))
    assert task.config == {"n_cranes": 2, "decisions": "task", "max_cycles": 12}
    assert task.make_env().decisions == "task" and task.max_steps(None) == 12
    bad = MulticraneTask.E3S2.get_task({"decisions": "plans"})
    with pytest.raises(ValueError, match="plans"):
        bad.make_env()
