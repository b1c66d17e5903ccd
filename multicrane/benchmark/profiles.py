"""What a sweep is: the named budget profiles and the runs (configuration x algorithm x seed,
with their ``TrainConfig`` settings) that a profile and the command line's choices expand to.

A sweep is configurations x algorithms x seeds under one budget. Each run is one
``multicrane.training.train`` run directory, ``<out>/<CONFIG>/<algo>/seed<k>/`` (see
``multicrane.benchmark.runstate`` for what it holds). Nothing here touches the disk.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from multicrane.benchmark.choices import SweepError, parse_configs
from multicrane.envs.paper_env import PAPER_CONFIGS

ALGOS = ("dqn", "double_dqn", "a2c", "ppo", "maskable_ppo")
# Ours, not an SB3 class (multicrane.training.lean_ppo): the `paper-budget` profile's learner.
LEAN_ALGOS = ("lean_ppo",)
RUNNABLE_ALGOS = ALGOS + LEAN_ALGOS
# The four algorithms the paper's text describes (vanilla DQN, double DQN, A2C, PPO).
PAPER_ALGOS = ("dqn", "double_dqn", "a2c", "ppo")
DEFAULT_ROOT = Path("runs") / "bench"


# -- profiles ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Profile:
    """A named budget: which runs, and how long each trains and is evaluated.

    ``hyperparams`` (``config_hyperparams``: some configurations' own, over them), ``n_envs``
    and ``shaping`` are per algorithm (``TrainConfig`` fields; ``shaping`` weighs the potential-
    based shaping of the learner's reward); absent algorithms use the paper's settings and reward.
    ``options``: other ``TrainConfig`` fields per algorithm (``potential``, ``shaping_gamma``).
    ``algo_configs``: the configurations of an algorithm that runs on fewer than ``configs``.
    """

    name: str
    configs: tuple[str, ...]
    algos: tuple[str, ...]
    seeds: tuple[int, ...]
    steps: int
    eval_every: int
    eval_episodes: int
    checkpoint_every: int
    about: str
    final_episodes: int | None = None  # the final evaluation (default: eval_episodes)
    hyperparams: dict[str, dict[str, Any]] = field(default_factory=dict)
    n_envs: dict[str, int] = field(default_factory=dict)
    shaping: dict[str, float] = field(default_factory=dict)
    options: dict[str, dict[str, Any]] = field(default_factory=dict)
    algo_configs: dict[str, tuple[str, ...]] = field(default_factory=dict)
    config_hyperparams: dict[str, dict[str, dict[str, Any]]] = field(default_factory=dict)


# The standard profile's learners: the paper's settings except these (our choice, for speed
# and learning within the budget; docs/benchmark.md lists each change). MaskablePPO trains on
# a shaped reward (TrainConfig.shaping / potential / shaping_gamma: the path potential with
# the undiscounted term, weight 1; docs/benchmark-experiments.md, fourth session). Double
# DQN's settings stay for `--algos double_dqn` (they do not learn within the budget and do
# not fit in its 2 hours beside MaskablePPO's 80 runs).
STANDARD_ALGOS = ("maskable_ppo",)
STANDARD_STEPS = 200_000
STANDARD_EVAL_EVERY = 50_000
STANDARD_SETTINGS: dict[str, dict[str, Any]] = {
    "double_dqn": {
        "n_envs": 8,
        "hyperparams": {"train_freq": 1, "gradient_steps": 1, "batch_size": 128,
                        "learning_starts": 1_000, "n_steps": 5},
    },
    "maskable_ppo": {
        "n_envs": 16,
        "hyperparams": {"n_steps": 128, "batch_size": 128},
        "shaping": 1.0,
        "options": {"potential": "path", "shaping_gamma": 1.0},
    },
}  # fmt: skip

ENV1_ENV2 = tuple(c for c in PAPER_CONFIGS if c[:2] in ("E1", "E2"))

PAPER_BUDGET_LEAN = {"n_envs": 64, "shaping": 1.0,  # ours; E4S3 256-256 below (docs/benchmark.md)
                     "hyperparams": {"batch_size": 256, "policy_kwargs": {"net_arch": [128, 128]}},
                     "options": {"potential": "path", "shaping_gamma": 1.0}}  # fmt: skip
PAPER_BUDGET_STEPS = 1_000_000

PROFILES: dict[str, Profile] = {
    p.name: p
    for p in (
        Profile(
            name="smoke",
            configs=("E1S1", "E2S2"),
            algos=ALGOS,
            seeds=(0,),
            steps=1_000,
            eval_every=500,
            eval_episodes=3,
            checkpoint_every=0,
            about="seconds: tries every algorithm once on two configurations (CI, trying "
            "the tool); learns nothing",
        ),
        # The quick profile: about 35 minutes with 2 workers on a 2-core machine (see
        # docs/benchmark.md for the estimate). DQN and double DQN take 90 % of the time
        # (one gradient step per environment step, ~450 steps/s); change `steps` or
        # `seeds` here to resize it.
        Profile(
            name="quick",
            configs=ENV1_ENV2,
            algos=ALGOS,
            seeds=(0, 1, 2),
            steps=30_000,
            eval_every=3_000,
            eval_episodes=10,
            final_episodes=50,
            checkpoint_every=0,  # runs of a minute: a checkpoint only when interrupted
            about="about 35 min on 2 cores: Env1 and Env2 (8 configurations), all five "
            "algorithms, 3 seeds, 30,000 steps per run",
        ),
        # Table I complete (issue 16): every configuration, MaskablePPO with learner
        # settings of ours (STANDARD_SETTINGS; each change is listed in docs/benchmark.md),
        # 5 seeds. Under 2 hours of CPU time on 2 cores by the estimate of
        # multicrane.benchmark.estimate (measured throughputs).
        Profile(
            name="standard",
            configs=PAPER_CONFIGS,
            algos=STANDARD_ALGOS,
            seeds=tuple(range(5)),
            steps=STANDARD_STEPS,
            eval_every=STANDARD_EVAL_EVERY,
            eval_episodes=4,
            final_episodes=20,
            checkpoint_every=0,  # runs of minutes: a checkpoint only when interrupted
            hyperparams={a: s["hyperparams"] for a, s in STANDARD_SETTINGS.items()},
            n_envs={a: s["n_envs"] for a, s in STANDARD_SETTINGS.items()},
            shaping={a: s["shaping"] for a, s in STANDARD_SETTINGS.items() if "shaping" in s},
            options={a: s["options"] for a, s in STANDARD_SETTINGS.items() if "options" in s},
            about="under 2 h on 2 cores: all 16 configurations, MaskablePPO with settings "
            "and a shaped training reward of ours (docs/benchmark.md), 5 seeds, "
            f"{STANDARD_STEPS:,} steps per run",
        ),
        Profile(
            name="paper-budget",
            configs=PAPER_CONFIGS,
            algos=("lean_ppo", *PAPER_ALGOS),
            seeds=tuple(range(5)),
            steps=PAPER_BUDGET_STEPS,
            eval_every=100_000,
            eval_episodes=4,
            final_episodes=20,
            checkpoint_every=100_000,
            **{key: {"lean_ppo": value} for key, value in PAPER_BUDGET_LEAN.items()},
            algo_configs={a: ENV1_ENV2 for a in PAPER_ALGOS},
            config_hyperparams={"lean_ppo": {"E4S3": {"policy_kwargs": {"net_arch": [256, 256]}}}},
            about="the paper's budget: lean PPO (64 copies, minibatch 256, 128-128 but E4S3 "
            "256-256, shaped reward) on all 16 configurations, the paper's four at its settings "
            f"on Env1/Env2, 5 seeds, {PAPER_BUDGET_STEPS:,} steps a run; ~30 h on 2 cores, lean "
            "PPO's 80 runs ~1.9 h",
        ),
        Profile(
            name="paper",
            configs=PAPER_CONFIGS,
            algos=PAPER_ALGOS,
            seeds=tuple(range(15)),
            steps=1_000_000,
            eval_every=10_000,
            eval_episodes=10,
            final_episodes=100,
            checkpoint_every=100_000,
            about="the paper's protocol: 16 configurations, DQN / double DQN / A2C / PPO, "
            "15 seeds, 1,000,000 steps per run, a curve point every 10,000 steps (the "
            "paper's epoch) over 10 episodes (Fig. 7); days of CPU time, meant for a cluster",
        ),
    )
}


# -- runs and sweeps -----------------------------------------------------------------------------


@dataclass(frozen=True)
class RunSpec:
    """One run of a sweep: its place in the grid and its ``TrainConfig`` keyword arguments."""

    config: str
    algo: str
    seed: int
    train: dict[str, Any] = field(compare=False)  # a run is known by (config, algo, seed)

    @property
    def name(self) -> str:
        return f"{self.config}/{self.algo}/seed{self.seed}"

    def dir(self, out: Path) -> Path:
        return Path(out) / self.config / self.algo / f"seed{self.seed}"


@dataclass(frozen=True)
class Sweep:
    """A profile with the command line's choices applied, and where its runs live."""

    name: str
    profile: str
    out: Path
    configs: tuple[str, ...]
    algos: tuple[str, ...]
    seeds: tuple[int, ...]
    steps: int
    eval_every: int
    eval_episodes: int
    checkpoint_every: int
    final_episodes: int | None = None
    hyperparams: dict[str, dict[str, Any]] = field(default_factory=dict)
    n_envs: dict[str, int] = field(default_factory=dict)
    shaping: dict[str, float] = field(default_factory=dict)
    options: dict[str, dict[str, Any]] = field(default_factory=dict)
    algo_configs: dict[str, tuple[str, ...]] = field(default_factory=dict)
    config_hyperparams: dict[str, dict[str, dict[str, Any]]] = field(default_factory=dict)

    def runs(self) -> list[RunSpec]:
        """Every run, configuration-major, then algorithm (on its ``algo_configs``), then seed."""
        return [
            RunSpec(config, algo, seed, self.train_kwargs(config, algo, seed))
            for config in self.configs
            for algo in self.algos
            if config in self.algo_configs.get(algo, self.configs)
            for seed in self.seeds
        ]

    def train_kwargs(self, config: str, algo: str, seed: int) -> dict[str, Any]:
        own = self.config_hyperparams.get(algo, {}).get(config, {})
        return jsonable(
            {
                "scenario": config,
                "paper": True,
                "algo": algo,
                "total_steps": self.steps,
                "seed": seed,
                "n_envs": self.n_envs.get(algo),
                "hyperparams": {**self.hyperparams.get(algo, {}), **own},
                "shaping": self.shaping.get(algo),
                "eval_every": self.eval_every,
                "eval_episodes": self.eval_episodes,
                "final_episodes": self.final_episodes,
                "checkpoint_every": self.checkpoint_every,
                "torch_threads": 1,
                **self.options.get(algo, {}),
            }
        )

    def budget(self) -> str:
        """One line: steps, seeds, evaluations."""
        return (
            f"{self.steps:,} environment steps per run, {len(self.seeds)} seed"
            f"{'s' if len(self.seeds) != 1 else ''} ({format_seeds(self.seeds)}), "
            f"curve evaluations every {self.eval_every:,} steps over {self.eval_episodes} "
            f"episodes, final evaluation over {self.final_episodes or self.eval_episodes} episodes"
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "profile": self.profile,
            "configs": list(self.configs),
            "algos": list(self.algos),
            "seeds": list(self.seeds),
            "steps": self.steps,
            "eval_every": self.eval_every,
            "eval_episodes": self.eval_episodes,
            "final_episodes": self.final_episodes,
            "checkpoint_every": self.checkpoint_every,
            "hyperparams": jsonable(self.hyperparams),
            "n_envs": dict(self.n_envs),
            "shaping": dict(self.shaping),
            "options": jsonable(self.options),
            "algo_configs": jsonable(self.algo_configs),
            "config_hyperparams": jsonable(self.config_hyperparams),
        }


def make_sweep(
    profile: str | Profile = "smoke",
    *,
    configs: Sequence[str] | None = None,
    algos: Sequence[str] | None = None,
    seeds: Sequence[int] | None = None,
    steps: int | None = None,
    eval_every: int | None = None,
    eval_episodes: int | None = None,
    out: str | Path | None = None,
    root: str | Path = DEFAULT_ROOT,
) -> Sweep:
    """The profile with the given choices. ``configs``/``algos``/``seeds`` pick runs (they
    share directories with the whole profile); ``steps``/``eval_every``/``eval_episodes``
    change every run, so unless ``out`` is given such a sweep gets its own directory
    (``<root>/<profile>-<steps>steps-eval<every>x<episodes>``)."""
    if isinstance(profile, str):
        if profile not in PROFILES:
            raise SweepError(f"unknown profile {profile!r}: one of {', '.join(PROFILES)}")
        profile = PROFILES[profile]
    chosen_configs = parse_configs(configs) if configs else profile.configs
    chosen_algos = tuple(algos) if algos else profile.algos
    for algo in chosen_algos:
        if algo not in RUNNABLE_ALGOS:
            raise SweepError(f"unknown algorithm {algo!r}: one of {', '.join(RUNNABLE_ALGOS)}")
    chosen_seeds = tuple(seeds) if seeds is not None and len(seeds) else profile.seeds
    for seed in chosen_seeds:
        if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
            raise SweepError(f"seed {seed!r}: seeds are non-negative integers")
    chosen = {"configuration": chosen_configs, "algorithm": chosen_algos, "seed": chosen_seeds}
    for label, values in chosen.items():
        twice = sorted({str(v) for v in values if list(values).count(v) > 1})
        if twice:
            raise SweepError(f"{label} given twice: {', '.join(twice)}")
    budget = {
        "steps": profile.steps if steps is None else steps,
        "eval_every": profile.eval_every if eval_every is None else eval_every,
        "eval_episodes": profile.eval_episodes if eval_episodes is None else eval_episodes,
    }
    for key, value in budget.items():
        low = 0 if key == "eval_every" else 1
        if not isinstance(value, int) or isinstance(value, bool) or value < low:
            raise SweepError(f"{key}={value!r}: must be an integer >= {low}")
    custom = budget != {k: getattr(profile, k) for k in budget}
    name = profile.name
    if custom:
        name = (
            f"{profile.name}-{budget['steps']}steps-eval{budget['eval_every']}"
            f"x{budget['eval_episodes']}"
        )
    return Sweep(
        name=name,
        profile=profile.name,
        out=Path(out) if out is not None else Path(root) / name,
        configs=chosen_configs,
        algos=chosen_algos,
        seeds=chosen_seeds,
        checkpoint_every=profile.checkpoint_every,
        final_episodes=profile.final_episodes,
        hyperparams={a: dict(h) for a, h in profile.hyperparams.items() if a in chosen_algos},
        n_envs={a: n for a, n in profile.n_envs.items() if a in chosen_algos},
        shaping={a: w for a, w in profile.shaping.items() if a in chosen_algos},
        options={a: dict(o) for a, o in profile.options.items() if a in chosen_algos},
        algo_configs={a: c for a, c in profile.algo_configs.items() if a in chosen_algos},
        config_hyperparams={
            a: d for a, d in profile.config_hyperparams.items() if a in chosen_algos
        },
        **budget,
    )


def format_seeds(seeds: Sequence[int]) -> str:
    """``0-14`` for a contiguous range, else the list."""
    seeds = list(seeds)
    if len(seeds) > 2 and seeds == list(range(seeds[0], seeds[0] + len(seeds))):
        return f"{seeds[0]}-{seeds[-1]}"
    return ", ".join(str(s) for s in seeds)


def jsonable(value: Any) -> Any:
    """The value as it reads back from JSON (tuples become lists), for comparisons."""
    return json.loads(json.dumps(value))
