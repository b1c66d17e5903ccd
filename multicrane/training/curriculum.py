"""A curriculum over generated sites: task-mode training on ``train`` sites that grow in size.

The set policy (``multicrane.training.set_policy``) reads any site that fits its limits, so it
can train on many sites at once. ``SiteCurriculum`` is the ``sites`` source of a
``SetVecEnv``: at each episode's reset a copy draws a site (from the copy's generator) from
the current stage's pool, and the stage grows when the policy finishes the sites it has:

- a stage's pool is the first ``pool`` sites of the generator's ``train`` distribution
  (seeds 0, 1, ... in order; ``multicrane.scenario.named_sets.train_member``) whose component count
  lies in the stage's range and that fit the limits (2-4 cranes by default, as in
  ``test-small``); the held-out sets use other seeds, so no evaluation site is trained on;
- the stage moves on once at least ``min_episodes`` episodes were played in it and the last
  ``window`` of them all but ``1 - success`` finished, and at the latest after
  ``max_episodes`` (a schedule: the policy sees every size even if a stage stalls).

Why growing size: on small sites (a few components) an episode is a handful of decisions and
the reward follows the choice closely, so the task head learns what a good task looks like
(near, ready, reachable) before long episodes with many cranes make the credit assignment
hard; the same weights then carry over because the network does not depend on the size.
The stage, its counters and every copy's generator are part of the checkpoint (exact resume).
"""

from __future__ import annotations

from collections import OrderedDict, deque
from dataclasses import dataclass
from functools import cache, lru_cache

from multicrane.core.schema import Scenario
from multicrane.envs.crane_env import MultiCraneEnv
from multicrane.scenario.named_sets import TRAIN_SEEDS, component_count, train_member
from multicrane.training.set_obs import SetLimits


@dataclass(frozen=True)
class Stage:
    """Sites with ``components`` (lo, hi) components, inclusive."""

    components: tuple[int, int]
    min_episodes: int = 200
    max_episodes: int = 2000


@dataclass(frozen=True)
class Plan:
    """A named curriculum: its stages, the limits its sites fit, and the promotion rule."""

    stages: tuple[Stage, ...]
    limits: SetLimits
    cranes: tuple[int, int] = (2, 4)
    pool: int = 16
    window: int = 100
    success: float = 0.95


CURRICULA: dict[str, Plan] = {
    # test-small's sizes (at most 29 components, 2-4 cranes, 289 tasks) fit these limits.
    "grow": Plan(
        stages=(Stage((1, 13)), Stage((14, 21)), Stage((22, 32), max_episodes=10**9)),
        limits=SetLimits(32, 4, 320),
    ),
    # One stage of every size: the schedule without growth, for comparison.
    "flat": Plan(stages=(Stage((1, 32), max_episodes=10**9),), limits=SetLimits(32, 4, 320)),
    # "flat" over 1,024 sites instead of 16: a policy trained on few sites learns those sites,
    # not a rule that carries over to new ones (Cobbe et al. 2019 measured it on CoinRun).
    "wide": Plan(
        stages=(Stage((1, 32), max_episodes=10**9),), limits=SetLimits(32, 4, 320), pool=1024
    ),
}
ENVS_PER_COPY = 32  # a copy keeps the environments of its last sites (each holds its caches)


@cache
def _site(seed: int) -> Scenario:
    return train_member(seed).scenario()


def _fits(seed: int, plan: Plan, stage: Stage) -> bool:
    params = dict(train_member(seed).params)
    lo, hi = stage.components
    return lo <= component_count(params) <= hi and (
        plan.cranes[0] <= params["cranes"] <= min(plan.cranes[1], plan.limits.cranes)
    )


SCAN = 20_000  # train seeds looked at for a stage's pool


@lru_cache(maxsize=16)
def stage_pool(name: str, index: int) -> tuple[int, ...]:
    """The train seeds of stage ``index`` of curriculum ``name`` (first fitting, in order)."""
    plan = CURRICULA[name]
    stage = plan.stages[index]
    out: list[int] = []
    for seed in TRAIN_SEEDS[:SCAN]:
        if len(out) == plan.pool:
            break
        if not _fits(seed, plan, stage):
            continue
        env = MultiCraneEnv(_site(seed), decisions="task")
        if plan.limits.fits(env.observation_layout):
            out.append(seed)
    if len(out) < plan.pool:
        raise ValueError(
            f"curriculum {name!r} stage {index}: only {len(out)} of {plan.pool} train sites "
            f"among seeds 0..{SCAN - 1} have {stage.components} components and fit "
            f"{plan.limits.to_dict()}"
        )
    return tuple(out)


VALIDATION_START = 500_000  # validation sites: train seeds from here (the pools scan 0..SCAN)


@lru_cache(maxsize=16)
def validation_pool(name: str, n: int) -> tuple[int, ...]:
    """``n`` train seeds of sites that fit curriculum ``name`` (any stage's size), for model
    selection (``TrainConfig.keep_best``): outside every stage's pool, so never trained on,
    and outside the held-out sets, so never an evaluation site."""
    plan = CURRICULA[name]
    lo = min(stage.components[0] for stage in plan.stages)
    hi = max(stage.components[1] for stage in plan.stages)
    out: list[int] = []
    for seed in TRAIN_SEEDS[VALIDATION_START:]:
        if len(out) == n:
            break
        if _fits(seed, plan, Stage((lo, hi))):
            env = MultiCraneEnv(_site(seed), decisions="task")
            if plan.limits.fits(env.observation_layout):
                out.append(seed)
    return tuple(out)


class SiteCurriculum:
    """The ``sites`` source of a ``SetVecEnv`` (see the module doc)."""

    def __init__(self, name: str, n_copies: int, max_steps: int | None = None,
                 reward: str = "paper"):  # fmt: skip
        if name not in CURRICULA:
            raise ValueError(f"unknown curriculum {name!r}: one of {', '.join(CURRICULA)}")
        self.name, self.plan = name, CURRICULA[name]
        self.max_steps = max_steps
        self.reward = reward
        self.stage = 0
        self.episodes = 0  # in this stage
        self.recent: deque[bool] = deque(maxlen=self.plan.window)
        self.history: list[dict] = []  # one entry per stage change
        self.site_of = [-1] * n_copies  # the train seed each copy plays
        self._envs: dict[int, OrderedDict[int, MultiCraneEnv]] = {}  # copy -> site -> env

    def __getstate__(self) -> dict:
        state = dict(self.__dict__)
        state["_envs"] = {}  # environments are rebuilt on demand (every reset is seeded)
        return state

    def __setstate__(self, state: dict) -> None:
        state.pop("_cache", None)  # (checkpoints before the per-copy cache)
        self.__dict__.update({"_envs": {}, **state})

    def env(self, seed: int, copy: int = 0) -> MultiCraneEnv:
        """Copy ``copy``'s environment of site ``seed``: kept while it is among the copy's
        last ``ENVS_PER_COPY`` sites, built again after (the same episodes: resets are
        seeded)."""
        envs = self._envs.setdefault(copy, OrderedDict())
        if seed in envs:
            envs.move_to_end(seed)
            return envs[seed]
        envs[seed] = env = MultiCraneEnv(
            _site(seed), decisions="task", max_steps=self.max_steps,
            reward=getattr(self, "reward", "paper"),  # (checkpoints before the option)
        )  # fmt: skip
        while len(envs) > ENVS_PER_COPY:
            envs.popitem(last=False)
        return env

    def first_env(self, copy: int) -> MultiCraneEnv:
        """A copy's environment before its first reset (stage 0's first site)."""
        seed = stage_pool(self.name, 0)[0]
        self.site_of[copy] = seed
        return self.env(seed, copy)

    def next_env(self, copy: int, rng) -> MultiCraneEnv:
        pool = stage_pool(self.name, self.stage)
        seed = pool[int(rng.integers(len(pool)))]
        self.site_of[copy] = seed
        return self.env(seed, copy)

    def record(self, copy: int, episode: dict) -> None:
        """One finished or truncated training episode; may move to the next stage."""
        self.episodes += 1
        self.recent.append(bool(episode["success"]))
        stage = self.plan.stages[self.stage]
        if self.stage + 1 >= len(self.plan.stages) or self.episodes < stage.min_episodes:
            return
        full = len(self.recent) == self.plan.window
        good = full and sum(self.recent) >= self.plan.success * self.plan.window
        if good or self.episodes >= stage.max_episodes:
            self.history.append(
                {"stage": self.stage, "episodes": self.episodes, "reason": "success" if good
                 else "schedule"}
            )  # fmt: skip
            self.stage += 1
            self.episodes = 0
            self.recent.clear()

    def describe(self) -> dict:
        return {"curriculum": self.name, "stage": self.stage, "history": list(self.history)}
