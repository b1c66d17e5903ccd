"""``multicrane train``: train a policy (paper algorithms, or parameter-sharing PPO for cranes)."""

from __future__ import annotations

import argparse
import functools
import os
from pathlib import Path

from multicrane.cli import progress
from multicrane.cli.common import add_environment_args, error, formatter, set_overrides

DESCRIPTION = """Train a policy: the paper's single-agent algorithms, or parameter-sharing PPO
for cranes (needs the 'train' extra).

    multicrane train --paper E2S2 --algo dqn --steps 200000 --seed 0
    multicrane train --scenario e2s2 --cranes 2 --algo maskable_ppo --steps 100000
    multicrane train --paper E1S1 --algo ppo --set learning_rate=1e-4 --set n_epochs=10
    multicrane train --paper E1S1 --algo lean_ppo --steps 1000000 [--device cuda]
    multicrane train --scenario hall-4c --cranes 4 --algo lean_ppo --steps 1000000
    multicrane train --backend rllib --scenario e3s2 --cranes 2 --steps 20000 [--address auto]
    multicrane train --scenario hall-4c --cranes 4 --decisions task --policy set --steps 100000
    multicrane train --scenario set:train --curriculum grow --steps 300000
    multicrane train --scenario hall-4c --cranes 4 --decisions task --policy set --events low
    multicrane train --scenario hall-4c --cranes 4 --decisions task --policy set \\
        --imitate lookahead --steps 100000

The run lives in --out (default runs/<name>): config.json, checkpoint/ (every
--checkpoint-every steps and on Ctrl-C), tb/ (tensorboard --logdir runs), then model.zip and
result.json. Running the same command again resumes an interrupted run exactly where it
stopped (or reports a finished one). Ctrl-C once: stop at the next update with a checkpoint;
twice: stop at once (back to the last checkpoint). Prints the final evaluation: greedy
actions on --eval-episodes fixed seeds, with the gap to the exact planner's return in paper
mode.

--backend rllib (needs the 'rllib' extra) trains one shared masked PPO policy for all cranes
with RLlib on a Ray cluster (--address auto, or ray://HOST:10001) or on a local Ray instance
(no --address); --envs sets its env runners (default 2), --set its PPOConfig.training
options. See multicrane.cli.train_rllib.

--events none|low|high trains (and evaluates) with site events (docs/uncertainty.md; both
decision levels, either backend); it is stored in config.json, so a resume, multicrane
evaluate and multicrane plan --policy RUN_DIR play the same level unless told otherwise.

--algo lean_ppo is our own PPO on the vector envs (multicrane.training.lean_ppo,
docs/training.md): paper mode, 256 copies by default, tens of thousands of steps per second,
--shaping, --potential and --shaping-gamma as for the SB3 learners;
multi-agent motion mode, one policy shared by the cranes (a row per crane), 32 copies by
default, with --events, --reward and --shaping as for maskable_ppo (not --auto, task
decisions, --imitate or the set policy); --device cuda trains it on a GPU (stored as its
train_device setting).
"""


def register(sub) -> None:
    p = sub.add_parser("train", help="train a policy (needs the 'train' extra)",
                       description=DESCRIPTION, **formatter())  # fmt: skip
    add_environment_args(p)
    p.add_argument(
        "--algo",
        default=None,
        help="paper: dqn, double_dqn, a2c, ppo, maskable_ppo, lean_ppo (default ppo); "
        "multi-agent: ppo, maskable_ppo, lean_ppo (default maskable_ppo)",
    )
    p.add_argument("--steps", type=int, default=100_000, help="budget in SB3 timesteps")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--envs", type=int, default=None, help="environment copies")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a hyper-parameter (repeatable)")  # fmt: skip
    p.add_argument("--eval-every", type=int, default=0, help="steps between curve evaluations")
    p.add_argument("--eval-episodes", type=int, default=20)
    p.add_argument("--checkpoint-every", type=int, default=50_000)
    p.add_argument("--mask-blocked-moves", choices=("on", "off"), default=None)
    p.add_argument("--shaping", type=float, default=None,
                   help="weight of the potential-based shaping term of the learner's reward "
                   "(0: off; default 1 multi-agent, 0 with --paper)")
    p.add_argument("--potential", choices=("distance", "path"), default="distance",
                   help="with --paper --shaping: the potential, Manhattan distances "
                   "(default) or shortest collision-free path lengths")  # fmt: skip
    p.add_argument("--shaping-gamma", type=float, default=None,
                   help="discount in the shaping term (default: the learner's gamma; "
                   "1: w (phi' - phi))")  # fmt: skip
    p.add_argument("--threads", type=int, default=1, help="torch threads (default 1)")
    p.add_argument("--device", default=None,
                   help="lean_ppo: where it trains, cpu (default) or cuda")  # fmt: skip
    p.add_argument("--policy", choices=("mlp", "set"), default=None,
                   help="multi-agent task mode: 'set' for the set-based shared policy "
                   "(default mlp; set with --curriculum)")  # fmt: skip
    p.add_argument("--curriculum", default=None, metavar="NAME",
                   help="train the set policy on generated 'train' sites: grow (16 sites a "
                   "stage, growing), flat (16 sites), wide (1,024 sites); evaluated on "
                   "set:test-small sites")  # fmt: skip
    p.add_argument("--set-limits", default=None, metavar="C,N,P",
                   help="set policy: padded components, cranes, tasks (default: the site's)")
    p.add_argument("--workers", type=int, default=1,
                   help="set policy: processes running the environment copies (default 1)")
    p.add_argument("--reward", choices=("paper", "makespan"), default="paper",
                   help="multi-agent: the environments' reward, the paper's (default) or "
                   "makespan (-1 per simulated step; what the makespan tables measure)")
    p.add_argument("--reward-scale", choices=("none", "site"), default="none",
                   help="set policy: 'site' divides the learner's reward by each site's static "
                   "work per crane, so sites of every size weigh alike (default none)")  # fmt: skip
    _imitation_options(p)
    p.add_argument("--keep-best", action="store_true",
                   help="keep the model of the curve point with the best return on validation "
                   "episodes (reset seeds 2,000,000...; needs --eval-every)")  # fmt: skip
    p.add_argument("--out", type=Path, default=None, help="run directory")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--backend", choices=("sb3", "rllib"), default="sb3",
                   help="sb3: stable-baselines3 in this process (default); rllib: RLlib on Ray")
    p.add_argument("--address", default=None,
                   help="rllib: Ray cluster to join (auto, ray://HOST:10001; default: local)")
    p.set_defaults(func=run)


def _imitation_options(p) -> None:
    """Imitation of a teacher and what refines it (the set policy's options)."""
    p.add_argument("--imitate", default=None, metavar="POLICY",
                   help="set policy: fit it to this planner's choices before PPO "
                   "(prioritized, lookahead, lookahead:candidates=20; docs/training.md)"
                   )  # fmt: skip
    p.add_argument("--imitate-episodes", type=int, default=64,
                   help="with --imitate: the teacher's episodes (default 64)")
    p.add_argument("--imitate-epochs", type=int, default=10,
                   help="with --imitate: passes over them (default 10)")
    p.add_argument("--imitate-demos", default=None, metavar="FILE.npz",
                   help="with --imitate: keep the teacher's episodes in this file (read if it "
                   "holds the same setting, else written): seeds can share them")
    p.add_argument("--imitate-soft", type=float, default=None, metavar="TAU",
                   help="with --imitate lookahead: fit softmax(-(makespan - best) / TAU) over "
                   "its candidates' makespans instead of its one choice (default: off)")
    p.add_argument("--imitate-stop", type=float, default=None, metavar="SHARE",
                   help="with --imitate: end each fit early once the greedy policy agrees with "
                   "the teacher on this share of its decision rows (1: an exact fit; default: "
                   "every epoch)")
    p.add_argument("--dagger", type=int, default=0, metavar="ROUNDS",
                   help="with --imitate (set policy): DAgger rounds after it, the teacher "
                   "labelling the policy's own episodes (default 0; docs/training.md)")
    p.add_argument("--expert-iteration", type=int, default=0, metavar="ROUNDS",
                   help="with --imitate lookahead (set policy): rounds of the look-ahead search "
                   "over the policy, distilled into it (default 0; docs/training.md)")
    p.add_argument("--round-episodes", type=int, default=32,
                   help="with --dagger or --expert-iteration: episodes labelled per round "
                   "(default 32)")
    p.add_argument("--clone-weight", type=float, default=0.0, metavar="W",
                   help="with --imitate and --imitate-demos: after every PPO update, cloning "
                   "steps on the teacher's rows, their gradient times W (default 0: none)")
    p.add_argument("--init-from", default=None, metavar="RUN_DIR",
                   help="start from the policy weights of this finished run (same algorithm "
                   "and network); with --imitate, skip the first imitation and run only "
                   "--dagger / --expert-iteration rounds on it (docs/training.md)")
    p.add_argument("--time-limit", type=float, default=None, metavar="SECONDS",
                   help="stop training after this much wall time (evaluations included) and "
                   "finish the run as if --steps were reached")
    p.add_argument("--planner-hint", action="store_true",
                   help="set policy: each task row also shows whether the prioritized planner "
                   "would start it for the crane now (the policy learns where to depart from it)")
    p.add_argument("--graph-features", action="store_true",
                   help="set policy: each task row also shows what its target holds up (the "
                   "longest chain of targets above it and how many depend on it)")


def build_config(args: argparse.Namespace):
    """The ``TrainConfig`` the options describe."""
    from multicrane.training import TrainConfig

    overrides = set_overrides(args.set)
    paper = args.paper is not None
    policy = args.policy or ("set" if args.curriculum else "mlp")
    if args.curriculum and args.scenario != "set:train":
        raise ValueError(f"--curriculum trains on --scenario set:train, not {args.scenario!r}")
    limits = None
    if args.set_limits:
        try:
            c, n, t = (int(v) for v in args.set_limits.split(","))
        except ValueError:
            raise ValueError(f"--set-limits {args.set_limits!r}: expected C,N,P") from None
        limits = {"components": c, "cranes": n, "tasks": t}
    mask = None if args.mask_blocked_moves is None else args.mask_blocked_moves == "on"
    algo = args.algo or ("ppo" if paper else "maskable_ppo")
    if args.device is not None:
        if algo != "lean_ppo":
            raise ValueError(f"--device is an option of --algo lean_ppo, not {algo}")
        overrides["train_device"] = args.device
    return TrainConfig(
        scenario=args.paper if paper else args.scenario,
        paper=paper,
        algo=algo,
        total_steps=args.steps,
        seed=args.seed,
        n_cranes=args.cranes,
        n_envs=args.envs,
        hyperparams=overrides,
        eval_every=args.eval_every,
        eval_episodes=args.eval_episodes,
        checkpoint_every=args.checkpoint_every,
        mask_blocked_moves=mask,
        auto=args.auto,
        decisions="task" if args.curriculum else args.decisions,
        shaping=args.shaping,
        potential=args.potential,
        shaping_gamma=args.shaping_gamma,
        torch_threads=args.threads,
        policy=policy,
        set_limits=limits,
        curriculum=args.curriculum,
        workers=args.workers,
        events=args.events,
        reward=args.reward,
        reward_scale=args.reward_scale,
        imitate=args.imitate,
        imitate_episodes=args.imitate_episodes,
        imitate_epochs=args.imitate_epochs,
        imitate_demos=args.imitate_demos,
        imitate_soft=args.imitate_soft,
        imitate_stop=args.imitate_stop,
        dagger=args.dagger,
        expert_iteration=args.expert_iteration,
        round_episodes=args.round_episodes,
        keep_best=args.keep_best,
        clone_weight=args.clone_weight,
        planner_hint=args.planner_hint,
        graph_features=args.graph_features,
        init_from=args.init_from,
        time_limit=args.time_limit,
    )


def teacher_of(cfg):
    """The policy factory ``cfg.imitate`` names (None without one)."""
    if cfg.imitate is None:
        return None
    import policies

    name, options = policies.split_spec(cfg.imitate)
    if cfg.expert_iteration and name == "lookahead":  # a search it can guide
        from policies.lookahead import LookaheadTeacher

        return LookaheadTeacher(**options)
    return policies.factory(cfg.imitate, paper=False)


def print_result(result: dict, run_dir: Path) -> None:
    f = result["final"]
    cfg = result["config"]
    print(
        f"{cfg['scenario']} {result['algorithm']} seed {cfg['seed']}: {result['steps']} steps "
        f"in {result['train_seconds']:.0f} s ({result['steps_per_second']:.0f} steps/s)"
    )
    sem = "-" if f["return_sem"] is None else f"{f['return_sem']:.2f}"
    line = (
        f"final evaluation ({f['episodes']} episodes, greedy actions): return "
        f"{f['return_mean']:.2f} ± {sem}, success {f['success_rate']:.0%}, "
        f"steps {f['steps_mean']:.1f}"
    )
    if f.get("optimal_mean") is not None:
        line += f"; optimal {f['optimal_mean']:.2f}, gap {f['gap']:.2f} ({f['gap_pct']:.1f} %)"
    print(line)
    print(f"model: {run_dir / 'model.zip'}  result: {run_dir / 'result.json'}")


def run(args: argparse.Namespace) -> int:
    os.environ.setdefault("OMP_NUM_THREADS", str(args.threads))
    if args.backend == "rllib":
        from multicrane.cli.train_rllib import run_rllib

        return run_rllib(args)
    if args.address is not None:
        return error(ValueError("--address is an option of --backend rllib"))
    from multicrane import ScenarioError
    from multicrane.training import ConfigError, train
    from multicrane.training.run_lock import RunLockedError

    try:
        cfg = build_config(args)
        run_dir = args.out or Path("runs") / cfg.name
        bar = not args.no_progress and progress.enabled()
        log = functools.partial(print, flush=True)  # shown at once when redirected to a file
        result = train(cfg, run_dir, progress_bar=bar, teacher=teacher_of(cfg), log=log)
    except (ConfigError, ScenarioError, ValueError, RunLockedError) as exc:
        return error(exc)
    if result is None:
        print(f"interrupted: run the same command again to resume ({run_dir})")
        return 130
    print_result(result, run_dir)
    return 0
