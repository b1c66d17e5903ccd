"""``multicrane train --backend rllib``: one shared masked PPO policy trained with RLlib on Ray.

The options of ``multicrane train`` that apply: ``--scenario`` (multi-agent only),
``--cranes``, ``--decisions``, ``--auto``, ``--steps`` (sampled joint steps), ``--seed``,
``--envs`` (env runners, default 2), ``--set KEY=VALUE`` (``PPOConfig.training`` keywords
such as ``lr`` or ``train_batch_size_per_learner``), ``--eval-episodes``, ``--out`` (default
``runs/rllib-<scenario>-<N>c-s<seed>``), and ``--address`` (``auto``: the cluster this
machine belongs to; default: a local Ray instance). See ``multicrane.integrations.rllib_train``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from multicrane.cli.common import error, needs_extra, set_overrides

# ``multicrane train`` options that the RLlib backend does not take, with their defaults.
SB3_ONLY = {
    "algo": None,
    "eval_every": 0,
    "checkpoint_every": 50_000,
    "mask_blocked_moves": None,
    "shaping": None,
    "policy": None,
    "curriculum": None,
    "reward_scale": "none",
    "set_limits": None,
    "workers": 1,
}


def run_rllib(args: argparse.Namespace) -> int:
    """Train with RLlib as the options say; the exit status."""
    from multicrane import ScenarioError

    if args.paper is not None:
        return error("--backend rllib trains the multi-agent env: use --scenario, not --paper")
    for name, default in SB3_ONLY.items():
        if getattr(args, name) != default:
            flag = "--" + name.replace("_", "-")
            return error(f"{flag} is an option of the sb3 backend, not of --backend rllib")
    try:
        import multicrane.integrations.rllib  # noqa: F401  (the extra's import check)
        from multicrane.integrations.rllib_train import train_rllib
    except ImportError:
        return needs_extra("train --backend rllib", "rllib")
    try:
        training = set_overrides(args.set)
    except ValueError as exc:
        return error(exc)
    cranes = f"{args.cranes}c-" if args.cranes else ""
    out = args.out or Path("runs") / f"rllib-{Path(args.scenario).stem}-{cranes}s{args.seed}"
    env_options = {"auto": args.auto, "decisions": args.decisions}
    if args.events is not None:  # site events: one more environment option
        env_options["events"] = args.events
    try:
        result = train_rllib(
            args.scenario, args.cranes, out, steps=args.steps, seed=args.seed,
            address=args.address, num_env_runners=2 if args.envs is None else args.envs,
            env_options=env_options, training=training, eval_episodes=args.eval_episodes,
        )  # fmt: skip
    except (ScenarioError, ValueError, FileNotFoundError) as exc:
        return error(exc)
    f = result["final"]
    print(
        f"{result['scenario']} rllib ppo (shared) seed {result['seed']}: {result['steps']} steps "
        f"in {result['iterations']} iterations, {result['train_seconds']:.0f} s"
    )
    sem = "-" if f["return_sem"] is None else f"{f['return_sem']:.2f}"
    print(
        f"final evaluation ({f['episodes']} episodes, greedy legal actions): return "
        f"{f['return_mean']:.2f} ± {sem}, success {f['success_rate']:.0%}, "
        f"steps {f['steps_mean']:.1f}"
    )
    print(f"checkpoint: {result['checkpoint']}  result: {out / 'result.json'}")
    return 0
