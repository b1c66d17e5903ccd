"""Training with stable-baselines3 (needs the ``train`` extra: ``pip install multicrane[train]``).

    from multicrane.training import TrainConfig, train
    result = train(TrainConfig("E2S2", paper=True, algo="dqn", total_steps=200_000), "runs/x")
    result = train(TrainConfig("e2s2", paper=False, n_cranes=2, algo="maskable_ppo"), "runs/y")

- ``vec_env``: ``CraneVecEnv``, parameter sharing over (copy, crane) rows for SB3.
- ``algorithms``: the algorithms and defaults (``docs/paper-spec.md`` section 8), double DQN.
- ``config``: ``TrainConfig``.  ``trainer``: ``train``, checkpoints and exact resume.
- ``model_policy``: a trained model as a policy, ``load_run``.
- ``seeding``: seeds of environment copies and evaluation episodes (no extra needed).

The names below are imported on first use, so ``multicrane.training.seeding`` (and this
package) import without the extra; using ``train`` and the others without it raises an
``ImportError`` that names the extra.

May import: every room below it (``core`` to ``ifc``), never ``benchmark``, ``reports``,
``integrations`` or ``cli``.
"""

from __future__ import annotations

import importlib

_WHERE = {
    "ConfigError": "config",
    "TrainConfig": "config",
    "train": "trainer",
    "CraneVecEnv": "vec_env",
    "load_run": "model_policy",
}

__all__ = sorted(_WHERE)


def require_extra() -> None:
    """Raise a clear ``ImportError`` when the training stack is not installed."""
    try:
        import sb3_contrib  # noqa: F401
        import stable_baselines3  # noqa: F401
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ImportError(
            "multicrane.training needs the training stack: pip install 'multicrane[train]' "
            f"(missing: {exc.name})"
        ) from exc


def __getattr__(name: str):
    if name not in _WHERE:
        raise AttributeError(f"module 'multicrane.training' has no attribute {name!r}")
    require_extra()
    value = getattr(importlib.import_module(f"multicrane.training.{_WHERE[name]}"), name)
    globals()[name] = value
    return value
