"""Capture MaskablePPO updates of a training run, then replay one with other settings.

    python tools/ppo_update_replay.py capture DIR --at STEP[,STEP ...] -- TRAIN_ARGS ...
    python tools/ppo_update_replay.py replay DIR/STEP [--variant NAME:KEY=VALUE,...] ...

``capture`` runs ``multicrane train TRAIN_ARGS`` and, before each update that starts at one of
the given crane decisions (SB3 logs an update's ``train/*`` figures at the *next* update's
step: the update logged at step S starts at S minus one rollout), saves into ``DIR/STEP/``
the model with its optimizer state (``model.zip``), the rollout buffer (``buffer.npz``) and
the random state the update draws its minibatches from (``rng.pt``). A training run is
deterministic on one machine, so the capture sees the same updates as the run it repeats;
it stops the run after the last one.

``replay`` loads a captured update and performs it once as captured ("as run") and once per
``--variant``: ``NAME:KEY=VALUE,...`` with keys ``lr``, ``eps`` and ``betas2`` (Adam's),
``n_epochs``, ``batch_size``, ``max_grad_norm``, ``ent_coef``, ``vf_coef``, ``clip_range``
and ``target_kl``. Each line gives SB3's ``approx_kl`` (the sampled actions only, last
epoch), then over the update's states with more than one allowed action: the KL between
the whole masked policies before and after (mean and max), their entropy before and after,
the probability of action 0 (waiting, in task mode) and the share whose greedy action
changed. docs/marl-results.md ("Why PPO from random weights collapsed") is
what it found. Needs the ``train`` extra.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import torch as th

BUFFER_FIELDS = ("observations", "actions", "rewards", "advantages", "returns",
                 "episode_starts", "log_probs", "values", "action_masks")  # fmt: skip
SETTINGS = {"lr": float, "eps": float, "beta2": float, "n_epochs": int, "batch_size": int,
            "max_grad_norm": float, "ent_coef": float, "vf_coef": float,
            "clip_range": float, "target_kl": float}  # fmt: skip


def capture(out: Path, steps: set[int], train_args: list[str]) -> int:
    from sb3_contrib import MaskablePPO

    from multicrane.cli import main

    original = MaskablePPO.train
    left = set(steps)

    def train(model):
        if model.num_timesteps in left:
            where = out / str(model.num_timesteps)
            where.mkdir(parents=True, exist_ok=True)
            model.save(where / "model.zip")  # with the optimizer's state
            buf = model.rollout_buffer
            np.savez_compressed(where / "buffer.npz",
                                **{k: getattr(buf, k) for k in BUFFER_FIELDS})  # fmt: skip
            # SB3 draws its minibatches from the legacy global generator
            th.save({"numpy": np.random.get_state(), "torch": th.get_rng_state()},  # noqa: NPY002
                    where / "rng.pt")  # fmt: skip
            left.discard(model.num_timesteps)
            print(f"captured the update at {model.num_timesteps} in {where}", flush=True)
        if not left:
            raise SystemExit(0)  # every update asked for is captured
        return original(model)

    MaskablePPO.train = train
    try:
        return main(["train", *train_args])
    finally:
        MaskablePPO.train = original


def _policy_log_probs(policy, obs: th.Tensor, masks: np.ndarray) -> th.Tensor:
    with th.no_grad():
        dist = policy.get_distribution(obs, action_masks=masks)
        return th.log_softmax(dist.distribution.logits, -1)


def replay_once(where: Path, settings: dict):
    """Performs the captured update with ``settings``: what it did to the policy, and the
    model after it."""
    from sb3_contrib import MaskablePPO
    from stable_baselines3.common.logger import Logger

    model = MaskablePPO.load(where / "model.zip", device="cpu")
    model.set_logger(Logger(folder=None, output_formats=[]))
    for group in model.policy.optimizer.param_groups:
        group["lr"] = settings.get("lr", group["lr"])
        group["eps"] = settings.get("eps", group["eps"])
        group["betas"] = (group["betas"][0], settings.get("beta2", group["betas"][1]))
    lr = model.policy.optimizer.param_groups[0]["lr"]
    model.lr_schedule = lambda _: lr
    for key in ("n_epochs", "batch_size", "max_grad_norm", "ent_coef", "vf_coef", "target_kl"):
        if key in settings:
            setattr(model, key, settings[key])
    if "clip_range" in settings:
        model.clip_range = lambda _: settings["clip_range"]
    with np.load(where / "buffer.npz") as data:
        for key in BUFFER_FIELDS:
            setattr(model.rollout_buffer, key, data[key].copy())
    model.rollout_buffer.generator_ready, model.rollout_buffer.full = False, True
    buf = model.rollout_buffer
    obs = th.as_tensor(buf.observations.reshape(-1, *buf.obs_shape))
    masks = buf.action_masks.reshape(len(obs), -1).astype(bool)
    rng = th.load(where / "rng.pt", weights_only=False)
    np.random.set_state(rng["numpy"])  # noqa: NPY002 (SB3 draws from it)
    th.set_rng_state(rng["torch"])
    before = _policy_log_probs(model.policy, obs, masks)
    model.train()
    after = _policy_log_probs(model.policy, obs, masks)
    many = th.as_tensor(masks.sum(-1) > 1)  # states with a choice: elsewhere nothing moves
    before, after = before[many], after[many]
    p0, p1 = before.exp(), after.exp()
    kl = th.where(p0 > 0, p0 * (before - after), th.zeros_like(p0)).sum(-1)
    entropy = lambda p, lp: -th.where(p > 0, p * lp, th.zeros_like(p)).sum(-1)  # noqa: E731
    return model, {
        "approx_kl": float(model.logger.name_to_value["train/approx_kl"]),
        "kl_mean": float(kl.mean()), "kl_max": float(kl.max()),
        "entropy": (float(entropy(p0, before).mean()), float(entropy(p1, after).mean())),
        "p_action0": (float(p0[:, 0].mean()), float(p1[:, 0].mean())),
        "greedy_changed": float((before.argmax(-1) != after.argmax(-1)).float().mean()),
    }


def _variant(text: str) -> tuple[str, dict]:
    name, _, body = text.partition(":")
    settings = {}
    for item in filter(None, body.split(",")):
        key, _, value = item.partition("=")
        if key not in SETTINGS:
            raise SystemExit(f"--variant {text!r}: unknown setting {key!r} "
                             f"(one of {', '.join(SETTINGS)})")  # fmt: skip
        settings[key] = SETTINGS[key](value)
    return name, settings


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    train_args = argv[argv.index("--") + 1 :] if "--" in argv else []
    argv = argv[: argv.index("--")] if "--" in argv else argv
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = p.add_subparsers(dest="command", required=True)
    c = sub.add_parser("capture", help="run multicrane train and save chosen updates")
    c.add_argument("out", type=Path)
    c.add_argument("--at", required=True, help="crane decisions at which updates start")
    r = sub.add_parser("replay", help="perform a captured update as run and with variants")
    r.add_argument("update", type=Path)
    r.add_argument("--variant", action="append", default=[], help="NAME:KEY=VALUE,...")
    args = p.parse_args(argv)
    th.set_num_threads(1)
    if args.command == "capture":
        if not train_args:
            p.error("capture: give the training run's arguments after --")
        return capture(args.out, {int(s) for s in args.at.split(",")}, train_args)
    print(f"{'variant':20s} {'approx_kl':>9s} {'KL mean':>8s} {'KL max':>7s} "
          f"{'entropy':>15s} {'P(action 0)':>15s} {'greedy changed':>14s}")  # fmt: skip
    for name, settings in [("as run", {}), *map(_variant, args.variant)]:
        _, f = replay_once(args.update, settings)
        print(f"{name:20s} {f['approx_kl']:9.4f} {f['kl_mean']:8.4f} {f['kl_max']:7.2f} "
              f"{f['entropy'][0]:6.3f} -> {f['entropy'][1]:5.3f} "
              f"{f['p_action0'][0]:6.3f} -> {f['p_action0'][1]:5.3f} "
              f"{f['greedy_changed']:14.3f}")  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main())
