"""Trained stable-baselines3 models as policies, and loading them from a run directory.

    from multicrane.training.model_policy import load_run
    model, config = load_run("runs/e2s2-maskable_ppo-s0")     # a directory ``train`` wrote
    policy = PaperModelPolicy(model, env)   # single-agent mode: policy(obs) -> action
    policy = SharedModelPolicy(model, env)  # multi-agent mode: policy(observations) -> actions

Both act greedily (``deterministic=True``); a masked model gets the environment's masks.
At the task level the cranes of a round choose in crane order, and a crane's choice removes
from the later cranes' options the tasks that share its component or target
(``exclusive_actions``): the environment would refuse them, and cranes that see the same
site (idle cranes without reach zones see exactly the same) would otherwise all pick the
same task.
A greedy team can reach a fixed point: every crane waits, time passes and nothing else
changes, so the same observations give the same waits until the step limit. The multi-agent
wrappers notice it (``WaitLoop``) and then start the one allowed task that the policy
prefers most (``break_waits=False`` keeps the plain greedy actions).
``policies.make`` plugs these into the policy registry (a run directory or ``model.zip`` as a
policy name).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from multicrane.tasks.task_list import exclusive_round, task_list
from multicrane.training.algorithms import algorithm
from multicrane.training.config import CHECKPOINT, TrainConfig
from multicrane.training.set_policy import BLOCKED


def _is_masked(model) -> bool:
    from sb3_contrib import MaskablePPO

    return isinstance(model, MaskablePPO) or getattr(model, "masked_policy", False)


class PaperModelPolicy:
    """A model trained on ``PaperAssemblyEnv``: ``policy(observation) -> action``."""

    def __init__(self, model, env, deterministic: bool = True):
        self.model = model
        self.env = env
        self.masked = _is_masked(model)
        self.deterministic = deterministic

    def __call__(self, observation) -> int:
        kwargs = {"action_masks": self.env.unwrapped.action_masks()} if self.masked else {}
        action, _ = self.model.predict(observation, deterministic=self.deterministic, **kwargs)
        return int(action)


class WaitLoop:
    """Whether a greedy team is stuck waiting: its last joint action was all waits, the clock
    has moved since, and every crane sees exactly what it saw then, the observation's own
    clock (``env.observation_layout.clock``, motion level only) aside. A deterministic
    policy would (all but) answer the same again, for ever: nothing outside the team changes
    the site while every crane waits (site events change the observation)."""

    def __init__(self, env):
        env = getattr(env, "unwrapped", env)
        self.state_of = lambda: env.sim.state
        self.clock = getattr(env.observation_layout, "clock", None)
        self.wait = env.wait_action
        self.last = None  # (clock, observations, all waited)

    def stuck(self, batch: np.ndarray) -> bool:
        if self.last is None:
            return False
        clock, seen, waited = self.last
        return (
            waited
            and self.state_of().step_count > clock
            and np.array_equal(self._timeless(batch), seen)
        )

    def remember(self, batch: np.ndarray, actions: np.ndarray) -> None:
        waited = bool(np.all(actions == self.wait))
        self.last = (self.state_of().step_count, self._timeless(batch), waited)

    def _timeless(self, batch: np.ndarray) -> np.ndarray:
        out = batch.copy()
        if self.clock is not None:
            out[:, self.clock] = 0
        return out


def break_wait(scores: np.ndarray, wait: int) -> np.ndarray:
    """All waits but one: the allowed non-wait action with the best score over all rows
    (``scores``: rows x actions, ``-inf`` or ``BLOCKED`` where not allowed; ``wait``: the
    waiting action's column)."""
    others = np.array(scores, dtype=np.float64)
    others[:, wait] = -np.inf
    actions = np.full(len(scores), wait, dtype=np.int64)
    row, col = np.unravel_index(np.argmax(others), others.shape)
    if others[row, col] > BLOCKED:  # else nobody may do anything but wait
        actions[row] = col
    return actions


def exclusive_actions(scores: np.ndarray, masks: np.ndarray, tasks, deterministic: bool = True
                      ) -> np.ndarray:  # fmt: skip
    """One action per crane row (``scores``: rows x actions, crane order): each row's best
    (or sampled) allowed action, after the earlier rows' tasks removed the tasks they conflict
    with (``tasks``: the site's ``TaskList``; ``multicrane.tasks.book.exclusive_round``)."""
    import torch as th

    scores = np.asarray(scores, dtype=np.float64)

    def choose(k: int, mask: np.ndarray) -> int:
        s = np.where(mask, scores[k], -np.inf)
        if deterministic:
            return int(np.argmax(s))
        return int(th.distributions.Categorical(logits=th.as_tensor(s)).sample())

    return exclusive_round(masks, tasks, choose)[1]


class SharedModelPolicy:
    """One model acting for every crane of a ``MultiCraneEnv`` (parameter sharing):
    ``policy(observations) -> {agent: action}``, all cranes in one batch (at the task level,
    exclusive claims: ``exclusive_actions``); greedy, it breaks a wait loop (``WaitLoop``)
    unless ``break_waits=False``."""

    def __init__(self, model, env, deterministic: bool = True, break_waits: bool = True):
        self.model = model
        self.env = env
        self.masked = _is_masked(model)
        self.deterministic = deterministic
        self.loop = WaitLoop(env) if deterministic and break_waits else None

    def __call__(self, observations: dict) -> dict:
        agents = list(observations)
        batch, masks = self._inputs(observations)
        tasks = task_list(self.env)
        if self.loop is not None and self.loop.stuck(batch):
            actions = break_wait(self._scores(batch, masks), self.loop.wait)
        elif tasks is not None:  # claims in a round are exclusive (see the module doc)
            actions = exclusive_actions(self._scores(batch, masks), masks, tasks,
                                        self.deterministic)  # fmt: skip
        else:
            actions = self._act(batch, masks)
        if self.loop is not None:
            self.loop.remember(batch, actions)
        return {a: int(x) for a, x in zip(agents, actions, strict=True)}

    def scores(self, observations: dict) -> np.ndarray:
        """Each crane's score of each action, one row per agent of ``observations`` in its
        order (logits; ``BLOCKED`` where the mask forbids): what the greedy choice ranks,
        and what a policy-guided search (``policies.lookahead``) orders its candidates by."""
        return self._scores(*self._inputs(observations))

    def _inputs(self, observations: dict) -> tuple[np.ndarray, np.ndarray]:
        batch = np.stack([o["observation"] for o in observations.values()])
        masks = np.stack([o["action_mask"] for o in observations.values()]).astype(bool)
        return batch, masks

    def _act(self, batch: np.ndarray, masks: np.ndarray) -> np.ndarray:
        kwargs = {"action_masks": masks} if self.masked else {}
        actions, _ = self.model.predict(batch, deterministic=self.deterministic, **kwargs)
        return np.asarray(actions)

    def _scores(self, batch: np.ndarray, masks: np.ndarray) -> np.ndarray:
        import torch as th

        if hasattr(self.model, "action_scores"):  # the lean PPO (multicrane.training.lean_ppo)
            return np.where(masks, self.model.action_scores(batch, masks), BLOCKED)
        policy = self.model.policy
        with th.no_grad():
            logits = policy.get_distribution(policy.obs_to_tensor(batch)[0]).distribution.logits
        return np.where(masks, logits.numpy(), BLOCKED)


class SetModelPolicy(SharedModelPolicy):
    """A set policy (``multicrane.training.set_policy``) acting for every crane of a task-mode
    ``MultiCraneEnv`` of any site that fits its limits: observations and masks are padded
    (``multicrane.training.set_obs``) and the cranes go in one batch. A site bigger than the
    model's limits is played by a copy of the network resized to it (same weights)."""

    def __init__(self, model, env, deterministic: bool = True, break_waits: bool = True):
        from multicrane.training.set_obs import Padder, union
        from multicrane.training.set_policy import SetActor

        super().__init__(model, env, deterministic, break_waits)
        limits = model.policy.features_extractor.limits
        if not limits.fits(env.observation_layout):
            if env.observation_layout.events is not None and not limits.events:
                limits.check(env.observation_layout, env.scenario.name)  # names the option
            limits = union([env.observation_layout, _Layout(**limits.to_dict())], limits.hint,
                           limits.graph)  # fmt: skip
        self.actor = SetActor(model.policy, limits)
        self.padder = Padder(env.observation_layout, self.actor.limits, env)

    def _inputs(self, observations: dict) -> tuple[np.ndarray, np.ndarray]:
        pad = self.padder
        proposed = dict(zip(self.env.possible_agents, pad.proposals(), strict=True))
        batch = np.stack([pad.pad(o["observation"], proposed=proposed[a])
                          for a, o in observations.items()])  # fmt: skip
        masks = np.stack([pad.pad_mask(o["action_mask"]) for o in observations.values()])
        return batch, masks

    def _act(self, batch: np.ndarray, masks: np.ndarray) -> np.ndarray:
        return self.actor(batch, masks, self.deterministic)

    def _scores(self, batch: np.ndarray, masks: np.ndarray) -> np.ndarray:
        return self.actor.logits(batch, masks).numpy()


class _Layout:
    """Table sizes in ``TaskLayout``'s attribute names (for ``set_obs.union``)."""

    def __init__(self, components: int, cranes: int, tasks: int, events: bool = False,
                 hint: bool = False, graph: bool = False):  # fmt: skip
        self.n_components, self.n_cranes, self.n_tasks = components, cranes, tasks
        self.events = (1, 1) if events else None  # only whether it is there matters


def _is_set(model) -> bool:
    from multicrane.training.set_policy import SetPolicy

    return isinstance(getattr(model, "policy", None), SetPolicy)


def model_policy(model, env, paper: bool, deterministic: bool = True, **options):
    """The wrapper of ``model`` for ``env``'s mode (``paper``: the single-agent mode);
    ``options``: ``break_waits`` for the multi-agent mode."""
    if paper:
        return PaperModelPolicy(model, env, deterministic=deterministic)
    cls = SetModelPolicy if _is_set(model) else SharedModelPolicy
    return cls(model, env, deterministic=deterministic, **options)


def load_run(path: str | Path, which: str = "final"):
    """(model, ``TrainConfig``) of a training run directory; ``which`` is ``"final"`` (its
    ``model.zip``), or ``"checkpoint"`` for the latest checkpoint of an unfinished run."""
    run_dir = Path(path)
    cfg = TrainConfig.load(run_dir / "config.json")
    algo = algorithm(cfg.algo, cfg.paper)
    model_path = run_dir / ("model.zip" if which == "final" else f"{CHECKPOINT}/model.zip")
    if not model_path.exists():
        raise FileNotFoundError(f"{model_path}: no {which} model in this run directory")
    return algo.cls.load(model_path, device="cpu"), cfg
