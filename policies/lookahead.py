"""A look-ahead task planner: the prioritized rule improved by rollouts on copies of the site.

``TaskLookahead`` drives ``MultiCraneEnv(decisions="task")``. In a round where some crane is
idle and may start a task, it compares a few joint actions: the prioritized planner's own
(``policies.task_planners.TaskPrioritized``), and for the first idle crane each of its
``candidates`` allowed tasks with the shortest static paths, and waiting. Each joint action is
played on a deep copy of the environment, which the prioritized planner then finishes; the
joint action whose copy finishes first is played (ties: the planner's own, then the earlier
candidate). This is the rollout algorithm of Bertsekas, Tsitsiklis and Wu ("Rollout
algorithms for combinatorial optimization", Journal of Heuristics 3, 1997) with the
prioritized planner as its base heuristic: the planner's own choice is always a candidate,
so a round never picks something the look-ahead expects to finish later than the planner.
It is not guaranteed to be shorter over a whole episode; it was shorter on all 50 hall-4c
evaluation episodes and on 46 of the 50 test-small sites, equal on the others
(docs/task-mode.md).

It costs ``candidates + 2`` finished episodes per decision round: seconds per episode on
hall-4c, against microseconds for the planner. Its use is as a stronger baseline and as the
teacher a learned policy imitates (``multicrane train --imitate lookahead``), whose network
then decides in under a millisecond.

A site with events is refused: the copy holds the episode's whole event schedule, so the
look-ahead would see late components and breakdowns before they happen.

A policy-guided search: with ``guide`` (a trained task-level model's policy, e.g.
``policies.make("lookahead", env, guide="runs/hall-s0")`` or ``lookahead:guide=runs/hall-s0``
on the command line) the first idle crane's candidates are its allowed tasks in the order of
the learned policy's scores instead of the shortest static paths, and the learned policy's own
joint action is one more candidate; the rollouts still judge (docs/marl-results.md, "Search at
decision time").

A search over a trained policy: with ``base`` a run directory on the command line
(``lookahead:base=runs/hall-s0``; ``policies.registry`` loads it as
``multicrane.training.expert_iteration.PolicyPlanner``) the learned set policy proposes the
round's first candidate and finishes every copy, so the search improves on the policy rather
than on the planner.

A time budget: with ``budget`` (seconds per round) the search stops trying candidates once the
next rollout might not end within it (the round's longest rollout so far as its cost; the
planner's own joint action is always tried): a planner for real time, whose choices then
depend on the machine's speed (no budget, the default, is deterministic).
"""

from __future__ import annotations

import copy
import time

import numpy as np

from policies.task_planners import TaskPrioritized, _book

UNFINISHED = 10**9  # the makespan of a copy that hits the step limit


class TaskLookahead:
    """The rollout planner over the prioritized rule (see the module doc).

    ``candidates``: how many of the first idle crane's allowed tasks (shortest static path
    first) are tried besides the planner's choice and waiting; ``max_searches`` and ``rank``
    go to the prioritized planner that proposes and finishes. ``base``: another base policy
    in its place, ``base(env) -> policy(observations) -> joint action`` (made for each copy
    and for the round itself, whose observations may hold only the masks), e.g. a learned
    policy (expert iteration, ``multicrane.training.expert_iteration``). ``guide``: a policy
    that proposes the candidates (see the module doc): ``guide(env, seed)`` makes it, and it
    answers ``scores(observations)`` (one row per crane, its actions' scores) besides
    ``(observations) -> joint action``, as a trained model's policy
    (``multicrane.training.model_policy``) does. ``budget``: seconds per round (see the
    module doc)."""

    def __init__(self, env, seed=None, candidates: int = 4, max_searches: int = 8,
                 rank: str = "list", base=None, guide=None, budget: float | None = None
                 ):  # fmt: skip
        self.env, _ = _book(env)
        if self.env.sim.schedule is not None or self.env.observation_layout.events is not None:
            raise ValueError(
                "lookahead plays copies of the environment, which hold the episode's future "
                "site events: use it on sites without events"
            )
        if not isinstance(candidates, int) or candidates < 0:
            raise ValueError(f"candidates={candidates!r}: must be an integer >= 0")
        if budget is not None and not (isinstance(budget, int | float) and budget > 0):
            raise ValueError(f"budget={budget!r}: seconds per round, a number > 0")
        self.seed = seed
        self.candidates = candidates
        self.budget = budget
        self.options = {"max_searches": max_searches, "rank": rank}
        self.base = base or (lambda env: TaskPrioritized(env, **self.options))
        self.guide = None if guide is None else guide(self.env, seed)
        if self.guide is not None and not hasattr(self.guide, "scores"):
            raise ValueError(f"guide={guide!r}: a trained task-level model's policy (a run "
                             "directory), which scores every crane's actions")  # fmt: skip
        self.rollouts = 0  # finished copies so far (its cost)
        # The last round's search values: (the first idle crane's agent, {its action: the
        # makespan its copy finished at}), None when the round compared nothing; imitation
        # with soft targets reads them (multicrane.training.soft_targets).
        self.values: tuple[str, dict[int, int]] | None = None

    def __call__(self, observations) -> dict:
        began = time.perf_counter()
        env = self.env
        base = self.base(env)(observations)
        joints = self._candidates(base, observations)
        self.values = None
        if len(joints) == 1:
            return base
        scores = self._scores(joints, began)
        agent = env.possible_agents[env.mode.task_book().idle_cranes()[0]]
        values: dict[int, int] = {}
        for joint, score in zip(joints, scores, strict=True):  # a crane action's best copy
            values[joint[agent]] = min(score, values.get(joint[agent], score))
        self.values = (agent, values)
        return joints[int(np.argmin(scores))]  # argmin: the first of equals, the planner's

    def _scores(self, joints: list[dict], began: float) -> list[int]:
        """Each joint action's finishing makespan on a copy; with a budget, those that the
        time left might not cover are not played (``UNFINISHED``)."""
        if self.budget is None:
            return [self._finish(joint) for joint in joints]
        scores: list[int] = []
        longest = 0.0  # the longest rollout of the round so far
        for k, joint in enumerate(joints):
            start = time.perf_counter()
            if k and start - began + longest > self.budget:  # the base's own: always
                scores.append(UNFINISHED)
                continue
            scores.append(self._finish(joint))
            longest = max(longest, time.perf_counter() - start)
        return scores

    def _candidates(self, base: dict, observations) -> list[dict]:
        """The planner's joint action, (guided) the learned policy's, then the first idle
        crane's alternatives: its allowed tasks in the guide's order or nearest first, and
        waiting."""
        env = self.env
        book = env.mode.task_book()
        idle = book.idle_cranes()
        if not idle or not book.carrier.may_start(env.sim.state.step_count):
            return [base]
        crane = idle[0]
        agent = env.possible_agents[crane]
        allowed = np.flatnonzero(book.allowed()[crane])
        out = [base]
        if self.guide is None:
            order = allowed[np.argsort(book.static_len[crane][allowed], kind="stable")]
        else:
            scores = self.guide.scores(observations)[list(observations).index(agent)]
            order = allowed[np.argsort(-scores[1 + allowed], kind="stable")]
            own = self.guide(observations)
            if own != base:
                out.append(own)
        tasks = book.tasks
        for action in [1 + int(p) for p in order[: self.candidates]] + [0]:
            clash = tasks.conflicts(action - 1) if action else np.zeros(len(tasks), dtype=bool)
            # Another crane the planner gave a task of the same component or target waits.
            joint = {a: (0 if a != agent and x and clash[x - 1] else x) for a, x in base.items()}
            joint[agent] = action
            if joint not in out:
                out.append(joint)
        return out

    def _copy(self):
        """A deep copy of the environment that shares what no episode changes (the scenario,
        the site, the task list and the static path lengths, a cache of the site's) and
        starts the episode's trace afresh: a rollout is never recorded, and the trace, which
        grows with the episode, was half of a copy's cost."""
        env = self.env
        mode = env.mode
        book = mode.task_book()
        shared = (env.scenario, env.sim.scenario, env.sim.site, env.observation_layout,
                  book.tasks, book.static)  # fmt: skip
        memo = {id(x): x for x in shared}
        for trace in (mode.trace, mode.trace_events, mode.trace_rewards, mode.decisions):
            memo[id(trace)] = []
        return copy.deepcopy(env, memo)

    def _finish(self, joint: dict) -> int:
        """The makespan of playing ``joint`` on a copy, then the base policy."""
        self.rollouts += 1
        env = self._copy()
        first = env.possible_agents[0]
        planner = self.base(env)
        observations = None
        while True:
            observations, _, terminations, truncations, _ = env.step(joint)
            if terminations[first]:
                return env.sim.state.step_count
            if truncations[first]:
                return UNFINISHED
            joint = planner(observations)


class LookaheadTeacher:
    """The look-ahead planner as a teacher factory (``make_teacher(env, seed)``) for
    ``multicrane train --imitate lookahead``; ``guided(base)``: the same search over another
    base policy (``TaskLookahead``'s ``base``), which expert iteration builds from the
    learned policy each round."""

    def __init__(self, base=None, **options):
        self.base, self.options = base, options

    def __call__(self, env, seed=None) -> TaskLookahead:
        return TaskLookahead(env, seed, base=self.base, **self.options)

    def guided(self, base) -> LookaheadTeacher:
        return LookaheadTeacher(base, **self.options)
