"""BenchMARL 1.5: MAPPO from BenchMARL's own Experiment on a multicrane scenario, a few
iterations (IPPO, QMIX, ...: swap the algorithm config; decisions="task" for task mode)."""

from pathlib import Path

import torch
from benchmarl.algorithms import MappoConfig
from benchmarl.experiment import Experiment, ExperimentConfig
from benchmarl.models.mlp import MlpConfig

from multicrane.integrations.benchmarl import MulticraneTask

torch.set_num_threads(1)
task = MulticraneTask.E3S2.get_task({"n_cranes": 2, "decisions": "motion", "max_cycles": 50})
config = ExperimentConfig.get_from_yaml()  # BenchMARL's defaults, then a small CPU run
config.sampling_device = config.train_device = config.buffer_device = "cpu"
config.max_n_iters, config.max_n_frames = 2, None
config.on_policy_collected_frames_per_batch = 100
config.on_policy_n_envs_per_worker = 2
config.on_policy_minibatch_size = 50
config.on_policy_n_minibatch_iters = 2
config.evaluation_episodes = 1
config.loggers = ["csv"]
config.checkpoint_at_end = True
config.save_folder = str(Path("runs/benchmarl").resolve())
Path(config.save_folder).mkdir(parents=True, exist_ok=True)
experiment = Experiment(
    task=task,
    algorithm_config=MappoConfig.get_from_yaml(),
    model_config=MlpConfig.get_from_yaml(),
    critic_model_config=MlpConfig.get_from_yaml(),
    seed=0,
    config=config,
)
experiment.run()  # a checkpoint, CSV scalars and a JSON of returns under experiment.folder_name
print(experiment.folder_name, experiment.total_frames)
