"""Training with stable-baselines3 (needs the ``train`` extra: ``pip install multicrane[train]``).

    from multicrane.training import TrainConfig, train
    result = train(TrainConfig("E2S2", paper=True, algo="dqn", total_steps=200_000), "runs/x")
    result = train(TrainConfig("e2s2", paper=False, n_cranes=2, algo="maskable_ppo"), "runs/y")

- ``vec_env``: ``CraneVecEnv``, parameter sharing over (copy, crane) rows for SB3.
- ``algorithms``: the algorithms and defaults (``docs/paper-spec.md`` section 8), double DQN.
- ``config``: ``TrainConfig``.  ``trainer``: ``train``, checkpoints and exact resume.
"""

try:
    import stable_baselines3  # noqa: F401
except ImportError as exc:  # pragma: no cover - depends on the installation
    raise ImportError(
        "multicrane.training needs the training stack: pip install 'multicrane[train]' "
        f"(missing: {exc.name})"
    ) from exc

from multicrane.training.config import ConfigError, TrainConfig
from multicrane.training.trainer import train
from multicrane.training.vec_env import CraneVecEnv

__all__ = ["ConfigError", "CraneVecEnv", "TrainConfig", "train"]
