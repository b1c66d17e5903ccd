"""Warm start: a fresh training run that begins from a finished run's policy weights.

``TrainConfig.init_from`` names a finished run directory (its ``model.zip``). The fresh
run's model takes that policy's weights (its optimizer starts afresh) before the teaching
step and PPO: fine-tuning a trained policy, or expert iteration over a policy that PPO
improved (``multicrane.training.teaching`` then skips the first imitation). Both runs must
have the same algorithm, policy kind and network (for a set policy: the same planner hint,
graph features and ``policy_kwargs``; the limits may differ, the set network does not depend
on the table sizes); anything else is refused by name, as is a directory without a finished
model.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from multicrane.training.config import ConfigError


def warm_start(model, cfg, log=print) -> dict:
    """Load ``cfg.init_from``'s policy weights into ``model`` (a fresh model of ``cfg``);
    the source and the weights' digest, for ``result.json`` and the teaching rounds' files."""
    from multicrane.training.model_policy import load_run

    where = f"init_from={cfg.init_from!r}"
    if not Path(cfg.init_from).is_dir():
        raise ConfigError(f"{where}: no such run directory")
    try:
        trained, source = load_run(cfg.init_from)
    except (FileNotFoundError, ConfigError) as exc:
        raise ConfigError(f"{where}: {exc}") from None
    mine = (cfg.algo, cfg.paper, cfg.policy)
    theirs = (source.algo, source.paper, source.policy)
    if mine != theirs:
        raise ConfigError(f"{where}: trained as (algo, paper, policy) = {theirs}, this run is "
                          f"{mine}")  # fmt: skip
    try:
        model.policy.load_state_dict(trained.policy.state_dict())
    except RuntimeError as exc:
        first = str(exc).strip().splitlines()[0]
        raise ConfigError(
            f"{where}: its network does not fit this run's ({first}); train with the same "
            "planner hint, graph features and policy_kwargs"
        ) from None
    digest = weights_digest(model.policy)
    log(f"{cfg.name}: starts from the policy of {cfg.init_from} (weights {digest[:12]})")
    return {"run": str(cfg.init_from), "weights": digest}


def weights_digest(policy) -> str:
    """A digest of a policy's weights: which policy guided a round (``teaching``'s files)."""
    h = hashlib.blake2b(digest_size=16)
    for name, tensor in sorted(policy.state_dict().items()):
        h.update(name.encode())
        h.update(tensor.detach().cpu().contiguous().numpy().tobytes())
    return h.hexdigest()
