"""Policies by name: the one table from a name to a policy, with the one seeding rule.

    import policies
    policy = policies.make("prioritized", env, seed=3)   # for the episode reset(seed=3) starts
    make_policy = policies.factory("runs/E2S2-ppo-s0")   # make_policy(env, seed), for evaluate()

Names (``names(paper)`` lists the built-in ones of a mode): ``random`` and ``greedy`` (both
modes), ``prioritized`` (multi-agent mode only; with ``decisions="task"`` these three are the
task-level planners of ``policies.task_planners``), ``replanning`` (the prioritized planner
by the name that says what it does on a site with events: it notices them and replans;
the same planner), ``static-plan`` (the static baseline of ``policies.static_plan``: one
plan at reset for the undisturbed site, executed in order; motion decisions only),
``lookahead`` (``policies.lookahead``: the prioritized planner improved by rollouts on copies
of the site; task decisions only, sites without events),
``optimal`` (the exact planner, single-agent mode only), or the path of a training run
directory or of its ``model.zip`` (needs the ``train`` extra; the model acts greedily). The
mode is the environment's: a PettingZoo ``ParallelEnv`` is the multi-agent mode, anything
else the single-agent benchmark mode.
``options`` go to the policy's constructor (e.g. ``rank="nearest"`` for ``prioritized``,
``patience`` for ``greedy``, ``candidates``, ``budget``, ``cranes``, ``guide`` and ``base``
(run directories) for ``lookahead``, ``deterministic`` and, in the multi-agent mode,
``break_waits`` for a trained model: ``multicrane.training.model_policy``). A name may
carry them itself, as the command line gives them: ``NAME:KEY=VALUE,KEY=VALUE``
(``lookahead:candidates=20``, ``prioritized:rank=nearest``; ``split_spec``); the whole text
is then the policy's label.

Seeding rule. A policy is made for one episode, the one ``env.reset(seed=seed)`` starts.
Whatever it draws at random comes from its own generator ``np.random.default_rng([seed, 1])``
(``policy_seed(seed)``), never from ``default_rng(seed)``: that is the environment's
generator, and a policy seeded with it would repeat the layout's draws. ``seed=None`` gives
an unseeded stream. Planners and trained models get the same stream (the prioritized and
exact planners and greedy model actions draw nothing), so an episode is a function of the
name, the options and the seed.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from multicrane.envs.decision_modes import task_level
from multicrane.episodes import policy_spec
from multicrane.episodes.rollout import is_multi_agent
from policies.random_policy import RandomMoves, RandomPolicy

POLICY_STREAM = 1
PAPER_NAMES = ("optimal", "greedy", "random")
MULTI_NAMES = ("prioritized", "greedy", "random", "replanning", "static-plan", "lookahead")
NAMES = ("greedy", "lookahead", "optimal", "prioritized", "random", "replanning", "static-plan")
TASK_NAMES = ("prioritized", "greedy", "random", "replanning", "lookahead")


class PolicyError(ValueError):
    """A policy that cannot be used here; the message says why."""


def split_spec(spec: str) -> tuple[str, dict[str, Any]]:
    """The name and options of a policy given as ``NAME:KEY=VALUE,KEY=VALUE`` (see the module
    doc; ``multicrane.episodes.policy_spec``): ``PolicyError`` names a malformed option."""
    try:
        return policy_spec.split_spec(spec)
    except policy_spec.SpecError as exc:
        raise PolicyError(str(exc)) from None


def names(paper: bool) -> tuple[str, ...]:
    """The built-in policy names of a mode (``paper``: the single-agent benchmark mode)."""
    return PAPER_NAMES if paper else MULTI_NAMES


def policy_seed(seed: int | None) -> list[int] | None:
    """The seed of a policy's own generator for the episode ``reset(seed=seed)`` starts."""
    return None if seed is None else [int(seed), POLICY_STREAM]


class ExactPlan:
    """The exact planner's episode (``multicrane.bounds.paper_optimum``), planned at the first call
    (right after the reset); then its actions one by one."""

    def __init__(self, env):
        self.env = env
        self.actions: list[int] | None = None

    def __call__(self, observation=None) -> int:
        if self.actions is None:
            from multicrane.bounds.paper_optimum import plan

            self.actions = list(plan(env=self.env.unwrapped).actions)
        return self.actions.pop(0) if self.actions else 0


def _builtin(name: str, paper: bool, env=None) -> Callable[..., Any]:
    """``build(env, seed, **options)`` for a built-in name of a mode (the task-level
    planners of ``policies.task_planners`` when ``env`` takes task-level decisions)."""
    if paper:
        if name == "optimal":
            return lambda env, seed, **o: ExactPlan(env, **o)
        if name == "greedy":
            from policies.paper_greedy import PaperGreedyPolicy

            return lambda env, seed, **o: PaperGreedyPolicy(env, **o)
        return lambda env, seed, **o: RandomMoves(seed=policy_seed(seed), **o)
    if name == "static-plan" and task_level(env):
        raise PolicyError("policy 'static-plan' drives motion decisions (decisions='motion')")
    if name == "lookahead" and not task_level(env):
        raise PolicyError("policy 'lookahead' drives task decisions (decisions='task')")
    if name == "lookahead":
        from policies.lookahead import TaskLookahead

        def build(env, seed, **o):
            try:
                return TaskLookahead(env, seed=policy_seed(seed), **o)
            except ValueError as exc:
                raise PolicyError(f"policy 'lookahead': {exc}") from None

        return build
    if name in TASK_NAMES and task_level(env):
        from policies import task_planners

        cls = {"prioritized": task_planners.TaskPrioritized, "greedy": task_planners.TaskGreedy,
               "random": task_planners.TaskRandom,
               "replanning": task_planners.TaskPrioritized}[name]  # fmt: skip
        return lambda env, seed, **o: cls(env, seed=policy_seed(seed), **o)
    if name == "static-plan":
        from policies.static_plan import StaticPlan

        return lambda env, seed, **o: StaticPlan(env, seed=policy_seed(seed), **o)
    if name in ("prioritized", "replanning"):
        from policies.prioritized import PrioritizedPlanner

        return lambda env, seed, **o: PrioritizedPlanner(env, seed=policy_seed(seed), **o)
    if name == "greedy":
        from policies.greedy import GreedyPolicy

        return lambda env, seed, **o: GreedyPolicy(env, seed=policy_seed(seed), **o)
    return lambda env, seed, **o: RandomPolicy(seed=policy_seed(seed), **o)


class Factory:
    """``make_policy(env, seed)`` for one policy name; ``label`` names it in tables."""

    def __init__(self, name: str, paper: bool | None = None, **options):
        self.name, given = split_spec(name)
        self.options = {**given, **options}
        self.model = None
        self.config = None
        self.label = self.name
        if self.name not in NAMES:
            self._load_model()
        if given:
            self.label = str(name)
        if self.name == "lookahead":  # run directories named by its options, loaded once
            if isinstance(self.options.get("guide"), str | Path):
                self.options["guide"] = self._trained("guide", self.options["guide"])
            if isinstance(self.options.get("base"), str | Path):
                self.options["base"] = self._rollout_base(self.options["base"])
        if paper is not None:
            self.check(paper)

    def _trained(self, key: str, path) -> Factory:
        """The trained model a look-ahead's ``guide`` or ``base`` names, loaded once."""
        trained = Factory(str(path), paper=False)
        if trained.model is None:
            raise PolicyError(f"policy {self.label!r}: {key}={str(path)!r} is not a trained "
                              "model (a run directory of multicrane train)")  # fmt: skip
        return trained

    def _rollout_base(self, path) -> Callable:
        """A look-ahead's ``base`` from a run directory: its set policy, greedy with claims
        as deployed, proposes each round's first candidate and finishes every copy
        (``multicrane.training.expert_iteration.PolicyPlanner``)."""
        trained = self._trained("base", path)
        if getattr(trained.config, "policy", "mlp") != "set":
            raise PolicyError(f"policy {self.label!r}: base={str(path)!r} is not a set policy "
                              "(multicrane train --policy set)")  # fmt: skip
        from multicrane.training.expert_iteration import PolicyPlanner

        policy = trained.model.policy
        return lambda env: PolicyPlanner(policy, env)

    def _load_model(self) -> None:
        path = Path(self.name)
        if not path.exists():
            raise PolicyError(
                f"policy {self.name!r}: not one of {', '.join(NAMES)} and no such run "
                "directory or model"
            )
        try:
            from multicrane.training import require_extra

            require_extra()
            from multicrane.training.model_policy import load_run
        except ImportError as exc:
            raise PolicyError(
                f"policy {self.name!r} is a trained model: it needs the 'train' extra: "
                "pip install 'multicrane[train]'"
            ) from exc
        run_dir = path.parent if path.suffix == ".zip" else path
        try:
            self.model, self.config = load_run(run_dir)
        except (FileNotFoundError, ValueError) as exc:
            raise PolicyError(f"policy {self.name!r}: {exc}") from None
        self.label = f"{self.config.algo} ({run_dir.name})"

    def check(self, paper: bool) -> None:
        """Raise ``PolicyError`` unless the policy can act in that mode."""
        if self.model is not None:
            if self.config.paper != paper:
                trained = (
                    "the single-agent benchmark mode" if self.config.paper
                    else "the multi-agent mode"
                )  # fmt: skip
                raise PolicyError(
                    f"policy {self.name!r} was trained in {trained} ({self.config.scenario})"
                )
        elif self.name not in names(paper):
            mode = "single-agent benchmark" if paper else "multi-agent"
            raise PolicyError(
                f"policy {self.name!r} does not act in the {mode} mode; "
                f"there: {', '.join(names(paper))}"
            )

    def __call__(self, env, seed: int | None = None):
        paper = not is_multi_agent(env)
        self.check(paper)
        try:
            if self.model is None:
                return _builtin(self.name, paper, env)(env, seed, **self.options)
            return self._model_policy(env, paper)
        except TypeError as exc:  # an option the policy does not take
            if "unexpected keyword argument" not in str(exc):
                raise
            raise PolicyError(f"policy {self.label!r}: {exc}") from None

    def _model_policy(self, env, paper: bool):
        from multicrane.training.model_policy import model_policy

        if getattr(self.config, "policy", "mlp") == "set":  # reads any task-mode site
            if not task_level(env):
                raise PolicyError(f"policy {self.name!r} is a set policy: it needs decisions=task")
            return model_policy(self.model, env, paper, **self.options)
        space = env.observation_space if paper else env.observation_space(env.possible_agents[0])
        shape = tuple((space if paper else space["observation"]).shape)
        trained = tuple(self.model.observation_space.shape)
        if trained != shape:
            raise PolicyError(
                f"policy {self.name!r} was trained on {self.config.scenario} with observations "
                f"of shape {trained}; this environment gives {shape}"
            )
        return model_policy(self.model, env, paper, **self.options)


def factory(name: str, paper: bool | None = None, **options) -> Factory:
    """``make_policy(env, seed)`` for ``name`` (a trained model is loaded once, here); with
    ``paper`` the name is checked against that mode now, not at the first episode."""
    return Factory(name, paper, **options)


def make(name: str, env, seed: int | None = None, **options):
    """The policy ``name`` for the episode ``env.reset(seed=seed)`` starts (see the module
    doc for the names and the seeding rule)."""
    return Factory(name, **options)(env, seed)
