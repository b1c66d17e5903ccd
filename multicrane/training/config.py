"""What one training run is: ``TrainConfig``, stored as ``config.json`` in its directory."""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from multicrane.envs.decision_modes import DECISION_MODES, DEFAULT_DECISIONS, decision_mode
from multicrane.envs.paper_env import PAPER_CONFIGS
from multicrane.episodes.policy_spec import spec_name
from multicrane.files import write_atomic

CHECKPOINT = "checkpoint"  # the run directory's checkpoint folder (see training.trainer)
DEFAULT_SHAPING = 1.0  # multi-agent mode; see multicrane.training.shaping
REWARD_SCALES = ("none", "site")  # the set policy's reward scaling (training.set_vec_env)
POTENTIALS = ("distance", "path")  # paper mode's shaping potentials (training.shaping)


class ConfigError(ValueError):
    """A training configuration that cannot be used; the message names the key and value."""


@dataclass
class TrainConfig:
    """One training run.

    ``scenario``: a paper configuration (``"E2S2"``) when ``paper`` is True, else a shipped
    scenario name or a path to a scenario file. ``algo``: ``dqn``, ``double_dqn``, ``a2c``,
    ``ppo`` or ``maskable_ppo`` (paper mode), ``ppo`` or ``maskable_ppo`` (multi-agent mode).
    ``total_steps``: the budget in SB3 timesteps, i.e. environment steps in paper mode and
    crane decisions (joint steps x cranes) in multi-agent mode; runs stop at the first
    update boundary at or past it. ``n_envs``: environment copies (default: the
    algorithm's). ``hyperparams``: overrides of the algorithm's defaults
    (``multicrane.training.algorithms``). ``eval_every``: steps between evaluations for the
    learning curve (0: only the final one); ``eval_episodes``: episodes per evaluation, on
    the fixed seeds of ``seeding.evaluation_seeds``; ``final_episodes``: episodes of the final
    evaluation (default: ``eval_episodes``). ``checkpoint_every``: steps between
    checkpoints (0: only on interruption). ``mask_blocked_moves``: paper mode's mask
    (default: on for ``maskable_ppo`` only). ``auto``/``max_steps``: multi-agent environment
    options; ``decisions``: ``"motion"`` or ``"task"`` (the multi-agent decision level).
    ``shaping``: weight of the potential-based shaping term added to the learner's reward
    (``multicrane.training.shaping``; multi-agent mode: default ``DEFAULT_SHAPING``; paper
    mode: default 0, the paper's reward; 0 turns it off). Evaluations, returns, curves and
    success always use the environment's own reward. ``potential`` (paper mode): the
    shaping's ``phi``, ``"distance"`` (Manhattan distances, the default) or ``"path"``
    (shortest collision-free path lengths); ``shaping_gamma``: the discount in the shaping
    term (None: the learner's own, the policy-invariant form; 1.0: ``w (phi' - phi)``).
    ``torch_threads``: 1 unless you have cores to spare. ``policy``: ``"mlp"`` (SB3's MLP on
    the flat observation) or ``"set"`` (``multicrane.training.set_policy``: MaskablePPO, task
    mode); ``set_limits``: the set policy's padded table sizes (``{"components", "cranes",
    "tasks"}``; default: the scenario's own, or the curriculum's); ``curriculum``: the name of
    a curriculum over the generator's ``train`` sites (``multicrane.training.curriculum``;
    ``scenario`` is then ``"set:train"``), evaluated on ``set:test-small`` sites; ``workers``:
    processes running the set policy's environment copies (``multicrane.training.set_workers``).
    ``events``: the site events of the multi-agent environments, ``"none"``, ``"low"`` or
    ``"high"`` (``multicrane.sim.events``; None: the scenario's own ``[events]`` table, if any).
    ``reward`` (multi-agent mode): the environments' reward, ``"paper"`` (the paper's team
    reward) or ``"makespan"`` (``-1`` per simulated step and the completion bonus: what the
    makespan comparisons measure; ``multicrane.envs.reward``). ``reward_scale`` (set
    policy): ``"site"`` divides the learner's reward by each site's static work per crane
    (``set_vec_env.site_work``), so sites of every size weigh alike (default ``"none"``).
    ``imitate`` (multi-agent
    MaskablePPO): the name of a teacher policy (``"prioritized"``, ``"lookahead"``) whose
    choices the fresh policy is fitted to before PPO starts
    (``multicrane.training.imitation``): ``imitate_episodes`` teacher episodes,
    ``imitate_epochs`` passes over them; ``imitate_demos``: a ``.npz`` file that keeps them
    (read when it exists and was made for the same setting, else written), so that several
    seeds share one set of teacher episodes. ``imitate_soft`` (with ``imitate="lookahead"``):
    fit soft targets at this temperature (in makespan steps) over the look-ahead's values of
    its candidates instead of its one choice (``multicrane.training.soft_targets``; None: the
    choice). ``imitate_stop``: every fit (imitation and each round) stops before
    ``imitate_epochs`` once the greedy agreement on the decision rows reaches this share
    (``imitation.clone``'s ``stop_at``; None: all epochs). ``dagger`` (set policy, with
    ``imitate``): that many DAgger rounds after the imitation, each labelling
    ``round_episodes`` episodes of the policy with the teacher's choices
    (``multicrane.training.dagger``);
    ``expert_iteration``: that many rounds after those, each distilling ``round_episodes``
    episodes of the teacher's search over the policy (``multicrane.training.expert_iteration``;
    a search teacher such as ``"lookahead"``). ``keep_best``: at each curve point, also
    play ``eval_episodes`` validation episodes (reset seeds 2,000,000 ...; with a curriculum,
    one on each of as many train sites outside its pools) and keep the model with the best
    validation return; the run's final model is that one (early stopping; the curve shows
    every point). ``clone_weight`` (with ``imitate`` and ``imitate_demos``): after every PPO
    update, cloning steps on the teacher's rows weighted by it, keeping PPO near the
    imitated policy (``multicrane.training.clone_term``; 0: none). ``planner_hint`` (set
    policy): each task row also shows whether the prioritized planner would start it for the
    observing crane now (``multicrane.training.set_obs``, the ``proposed`` column).
    ``graph_features`` (set policy): each task row also shows what its target holds up (the
    ``chain`` and ``dependents`` columns of ``multicrane.training.set_obs``).
    ``init_from``: a finished run directory whose policy weights the fresh run starts from
    (``multicrane.training.warm_start``; same algorithm, policy kind and network); with
    ``imitate`` it skips the first imitation and runs only the rounds (``dagger``,
    ``expert_iteration``) on that policy, e.g. expert iteration after PPO. ``time_limit``:
    seconds of training wall time (curve evaluations included) after which the run stops at
    the next update boundary and finishes as if its budget were spent (None: the budget only).
    """

    scenario: str = "E2S2"
    paper: bool = True
    algo: str = "ppo"
    total_steps: int = 100_000
    seed: int = 0
    n_cranes: int | None = None
    n_envs: int | None = None
    hyperparams: dict[str, Any] = field(default_factory=dict)
    eval_every: int = 0
    eval_episodes: int = 20
    final_episodes: int | None = None
    checkpoint_every: int = 50_000
    mask_blocked_moves: bool | None = None
    auto: bool = False
    max_steps: int | None = None
    decisions: str = "motion"
    shaping: float | None = None
    potential: str = "distance"
    shaping_gamma: float | None = None
    torch_threads: int = 1
    policy: str = "mlp"
    set_limits: dict[str, int] | None = None
    curriculum: str | None = None
    workers: int = 1
    events: str | None = None
    reward: str = "paper"
    reward_scale: str = "none"
    imitate: str | None = None
    imitate_episodes: int = 64
    imitate_epochs: int = 10
    imitate_demos: str | None = None
    imitate_soft: float | None = None
    imitate_stop: float | None = None
    dagger: int = 0
    expert_iteration: int = 0
    round_episodes: int = 32
    keep_best: bool = False
    clone_weight: float = 0.0
    planner_hint: bool = False
    graph_features: bool = False
    init_from: str | None = None
    time_limit: float | None = None

    def __post_init__(self) -> None:
        if self.paper:
            if str(self.scenario).upper() not in PAPER_CONFIGS:
                raise ConfigError(
                    f"scenario={self.scenario!r}: paper mode needs one of "
                    f"{', '.join(PAPER_CONFIGS)}"
                )
            self.scenario = str(self.scenario).upper()
            if self.n_cranes not in (None, 1):
                raise ConfigError(f"n_cranes={self.n_cranes!r}: paper mode has one crane")
        if self.decisions not in DECISION_MODES:
            names = " or ".join(repr(name) for name in DECISION_MODES)
            raise ConfigError(f"decisions={self.decisions!r}: must be {names}")
        if self.paper and self.decisions != DEFAULT_DECISIONS:
            raise ConfigError(
                f"decisions={self.decisions!r} is a multi-agent option, not paper mode"
            )
        for name in ("total_steps", "eval_episodes", "torch_threads", "imitate_episodes",
                     "imitate_epochs", "round_episodes"):  # fmt: skip
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < 1:
                raise ConfigError(f"{name}={value!r}: must be a positive integer")
        for name in ("seed", "eval_every", "checkpoint_every", "dagger",
                     "expert_iteration"):  # fmt: skip
            value = getattr(self, name)
            if not isinstance(value, int) or isinstance(value, bool) or value < 0:
                raise ConfigError(f"{name}={value!r}: must be a non-negative integer")
        for name in ("n_cranes", "n_envs", "max_steps", "final_episodes"):
            value = getattr(self, name)
            if value is not None and (not isinstance(value, int) or value < 1):
                raise ConfigError(f"{name}={value!r}: must be a positive integer or None")
        if self.shaping is not None and (
            not isinstance(self.shaping, (int, float)) or self.shaping < 0
        ):
            raise ConfigError(f"shaping={self.shaping!r}: must be a number >= 0")
        if self.potential not in POTENTIALS:
            raise ConfigError(f"potential={self.potential!r}: one of {', '.join(POTENTIALS)}")
        if self.potential != "distance" and not self.paper:
            raise ConfigError(f"potential={self.potential!r}: a paper-mode option")
        if self.shaping_gamma is not None and (
            not _is_real(self.shaping_gamma) or not 0 <= self.shaping_gamma <= 1
        ):
            raise ConfigError(
                f"shaping_gamma={self.shaping_gamma!r}: must be a number in [0, 1] or None"
            )
        if self.time_limit is not None and (not _is_real(self.time_limit) or self.time_limit <= 0):
            raise ConfigError(f"time_limit={self.time_limit!r}: must be seconds > 0 or None")
        self._check_set_policy()
        self._check_imitation()
        check_clone_weight(self.clone_weight, self.imitate, self.imitate_demos)
        self._check_keep_best()
        self._check_events()
        from multicrane.envs.crane_env import REWARDS

        if self.reward not in REWARDS:
            raise ConfigError(f"reward={self.reward!r}: one of {', '.join(REWARDS)}")
        if self.reward_scale not in REWARD_SCALES or (
            self.reward_scale != "none" and self.policy != "set"
        ):
            raise ConfigError(f"reward_scale={self.reward_scale!r}: 'none', or 'site' with the "
                              "set policy")  # fmt: skip
        if self.paper and self.reward != "paper":
            raise ConfigError(f"reward={self.reward!r}: a multi-agent option, not paper mode")
        if not isinstance(self.hyperparams, dict):
            raise ConfigError(f"hyperparams={self.hyperparams!r}: must be a mapping")
        from multicrane.training.algorithms import algorithm, hyperparameters

        try:
            algo = algorithm(self.algo, self.paper)
        except ValueError as exc:
            raise ConfigError(f"algo={self.algo!r}: {exc}") from None
        try:
            hyperparameters(algo, None, self.hyperparams)
        except ValueError as exc:
            raise ConfigError(f"hyperparams: {exc}") from None

    def _check_set_policy(self) -> None:
        if self.policy not in ("mlp", "set"):
            raise ConfigError(f"policy={self.policy!r}: must be 'mlp' or 'set'")
        if not isinstance(self.workers, int) or isinstance(self.workers, bool) or self.workers < 1:
            raise ConfigError(f"workers={self.workers!r}: must be a positive integer")
        if self.policy == "mlp" and self.workers != 1:
            raise ConfigError(f"workers={self.workers!r}: needs policy='set'")
        for name in ("planner_hint", "graph_features"):
            if not isinstance(getattr(self, name), bool):
                raise ConfigError(f"{name}={getattr(self, name)!r}: must be true or false")
        if self.policy == "mlp":
            for name in ("set_limits", "curriculum"):
                if getattr(self, name) is not None:
                    raise ConfigError(f"{name}={getattr(self, name)!r}: needs policy='set'")
            for name in ("planner_hint", "graph_features"):
                if getattr(self, name):
                    raise ConfigError(f"{name}=True: needs policy='set'")
            return
        task = decision_mode(self.decisions).task_level
        if self.paper or not task or self.algo != "maskable_ppo":
            raise ConfigError(
                "policy='set' needs the multi-agent mode with decisions='task' and "
                f"algo='maskable_ppo' (got paper={self.paper}, decisions={self.decisions!r}, "
                f"algo={self.algo!r})"
            )
        if self.set_limits is not None:
            from multicrane.training.set_obs import SetLimits

            if not isinstance(self.set_limits, dict) or set(self.set_limits) != {
                "components", "cranes", "tasks"
            }:
                raise ConfigError(
                    f"set_limits={self.set_limits!r}: needs the keys components, cranes, tasks"
                )
            try:
                SetLimits(**self.set_limits)
            except ValueError as exc:
                raise ConfigError(str(exc)) from None
        if self.curriculum is not None:
            from multicrane.training.curriculum import CURRICULA

            if self.curriculum not in CURRICULA:
                raise ConfigError(
                    f"curriculum={self.curriculum!r}: one of {', '.join(CURRICULA)}"
                )
            if self.scenario != "set:train":
                raise ConfigError(
                    f"scenario={self.scenario!r}: a curriculum trains on 'set:train'"
                )

    def _check_keep_best(self) -> None:
        if not isinstance(self.keep_best, bool):
            raise ConfigError(f"keep_best={self.keep_best!r}: must be True or False")
        if self.keep_best and not self.eval_every:
            raise ConfigError("keep_best=True: needs eval_every > 0 (the points it chooses from)")

    def _check_imitation(self) -> None:
        init = self.init_from
        if init is not None and (not isinstance(init, str) or not init):
            raise ConfigError(f"init_from={init!r}: must be a run directory's path")
        if init is not None and self.imitate is not None and not (
            self.dagger or self.expert_iteration
        ):
            raise ConfigError(
                f"init_from={init!r} with imitate={self.imitate!r}: a warm start skips the "
                "first imitation and runs only its rounds: give dagger or expert_iteration"
            )
        if self.imitate is None:
            for name in ("imitate_demos", "dagger", "expert_iteration"):
                if getattr(self, name):
                    raise ConfigError(f"{name}={getattr(self, name)!r}: needs imitate")
            for name in ("imitate_soft", "imitate_stop"):
                if getattr(self, name) is not None:
                    raise ConfigError(f"{name}={getattr(self, name)!r}: needs imitate")
            return
        if not isinstance(self.imitate, str) or not self.imitate:
            raise ConfigError(f"imitate={self.imitate!r}: must be a teacher policy's name")
        if self.paper or self.algo != "maskable_ppo":
            raise ConfigError(
                f"imitate={self.imitate!r}: needs the multi-agent mode and algo='maskable_ppo'"
            )
        for name in ("dagger", "expert_iteration"):
            if getattr(self, name) and self.policy != "set":
                raise ConfigError(f"{name}={getattr(self, name)!r}: needs policy='set'")
        stop = self.imitate_stop
        if stop is not None and (not _is_real(stop) or not 0 < stop <= 1):
            raise ConfigError(f"imitate_stop={stop!r}: must be a share of rows in (0, 1]")
        soft = self.imitate_soft
        if soft is not None:
            if not _is_real(soft) or not soft >= 0:
                raise ConfigError(f"imitate_soft={soft!r}: must be a temperature >= 0")
            if spec_name(self.imitate) != "lookahead":  # with its options or not
                raise ConfigError(
                    f"imitate_soft={soft!r}: needs imitate='lookahead' (the teacher that values "
                    "its candidates)"
                )

    def _check_events(self) -> None:
        if self.events is None:
            return
        from multicrane.sim.events import LEVELS

        if self.events not in LEVELS:
            raise ConfigError(f"events={self.events!r}: one of {', '.join(LEVELS)} (or None)")
        if self.paper:
            raise ConfigError(f"events={self.events!r}: a multi-agent option, not paper mode")
        if self.curriculum is not None:
            raise ConfigError(f"events={self.events!r}: not available with a curriculum")

    @property
    def final_eval_episodes(self) -> int:
        return self.final_episodes or self.eval_episodes

    @property
    def shaping_weight(self) -> float:
        if self.paper:
            return 0.0 if self.shaping is None else float(self.shaping)
        return DEFAULT_SHAPING if self.shaping is None else float(self.shaping)

    @property
    def name(self) -> str:
        """A directory name for the run: ``E2S2-ppo-s0`` or ``hall-4c-2c-maskable_ppo-s3``."""
        scen = Path(str(self.scenario)).stem
        cranes = f"-{self.n_cranes}c" if self.n_cranes and not self.paper else ""
        return f"{scen}{cranes}-{self.algo}-s{self.seed}"

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "config") -> TrainConfig:
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ConfigError(f"{source}: unknown key(s) {', '.join(unknown)}")
        return cls(**data)

    def save(self, path: Path) -> None:
        write_atomic(path, json.dumps(self.to_dict(), indent=2, sort_keys=True) + "\n")

    @classmethod
    def load(cls, path: Path) -> TrainConfig:
        try:
            data = json.loads(Path(path).read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise ConfigError(f"{path}: cannot read the run configuration ({exc})") from None
        if not isinstance(data, dict):
            raise ConfigError(f"{path}: expected a JSON object")
        return cls.from_dict(data, source=str(path))

    def differences(self, other: TrainConfig) -> list[str]:
        """``key: mine != other`` for each differing field."""
        a, b = self.to_dict(), other.to_dict()
        return [f"{k}: {a[k]!r} != {b[k]!r}" for k in a if a[k] != b[k]]


def check_clone_weight(weight, imitate, demos) -> None:
    """``ConfigError`` unless ``weight`` is a finite number >= 0, and, when above 0, the run
    imitates a teacher (``imitate``) and keeps its rows in a file (``demos``)."""
    if not _is_real(weight) or not (math.isfinite(weight) and weight >= 0):
        raise ConfigError(f"clone_weight={weight!r}: must be a finite number >= 0")
    if weight > 0 and imitate is None:
        raise ConfigError(
            f"clone_weight={weight!r}: needs imitate (the teacher whose rows it clones)"
        )
    if weight > 0 and demos is None:
        raise ConfigError(
            f"clone_weight={weight!r}: needs imitate_demos (the file of the teacher's rows, "
            "read again for PPO and on resume)"
        )


def _is_real(value) -> bool:
    """An int or a float, not a bool (``True`` is an ``int`` to Python)."""
    return isinstance(value, int | float) and not isinstance(value, bool)
