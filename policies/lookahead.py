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

Agent-by-agent rollout: with ``cranes`` = m > 1 the round's first m idle cranes search one
after the other (the multiagent rollout of Bertsekas, "Multiagent rollout algorithms and
reinforcement learning", 2020): the next idle crane tries its candidates in the best joint
action found so far, the cranes before it keeping their choices, and the best copy is kept
(the joint action so far on ties, so each crane can only shorten the round's expected
finish). A round with k idle cranes then costs up to about k times the rollouts.

Two base heuristics: with another ``base`` and ``planner=True`` each joint action is
finished twice, by the base and by the prioritized planner, and its value is the shorter
finish; the planner's own joint action is one more candidate (rollout with several base
heuristics, Bertsekas, Tsitsiklis and Wu 1997: the search then improves on both). It costs
about 1.5 times the rollouts (the planner's are the cheaper).

A time budget: with ``budget`` (seconds per round) the search stops trying candidates once the
next rollout might not end within it (the round's longest rollout so far as its cost), and a
rollout still running at the round's deadline is stopped and counts as unfinished, the base's
own included: the round then plays the best joint action whose copy finished, or the base's
own. The deadline is ``RESERVE`` before the budget's end, which leaves room for the rollout
step under way and the round's return, so a round keeps within its budget whatever the site,
the base policy or the machine's load. Python's cyclic garbage collector is paused while a
budgeted round's rollouts run: a full collection in a process that holds trained models
takes 0.1-0.2 s, which landed past the deadline; the copies hold almost no reference
cycles, so reference counting frees them and nothing piles up. A planner for real time,
whose choices then depend on the machine's speed (no budget, the default, is deterministic).
"""

from __future__ import annotations

import time

import numpy as np

from multicrane.envs.rollout_copy import collector_paused, has_events, rollout_copy
from policies.task_planners import TaskPrioritized, _book

UNFINISHED = 10**9  # the makespan of a copy that hits the step limit (or the round's deadline)
RESERVE = 0.02  # seconds: the rollouts stop this long before a budget ends (a tenth at most)


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
    (``multicrane.training.model_policy``) does. ``budget``: seconds per round; ``cranes``:
    how many idle cranes search, one after the other; ``planner``: with another ``base``,
    the prioritized planner finishes each copy too (all three: see the module doc)."""

    def __init__(self, env, seed=None, candidates: int = 4, max_searches: int = 8,
                 rank: str = "list", base=None, guide=None, budget: float | None = None,
                 cranes: int = 1, planner: bool = False):  # fmt: skip
        self.env, _ = _book(env)
        if has_events(self.env):
            raise ValueError(
                "lookahead plays copies of the environment, which hold the episode's future "
                "site events: use it on sites without events"
            )
        if not isinstance(candidates, int) or candidates < 0:
            raise ValueError(f"candidates={candidates!r}: must be an integer >= 0")
        if budget is not None and not (isinstance(budget, int | float) and budget > 0):
            raise ValueError(f"budget={budget!r}: seconds per round, a number > 0")
        if not isinstance(cranes, int) or isinstance(cranes, bool) or cranes < 1:
            raise ValueError(f"cranes={cranes!r}: how many idle cranes search, an integer >= 1")
        self.seed = seed
        self.candidates = candidates
        self.budget = budget
        self.cranes = cranes
        self._longest = 0.0  # the round's longest rollout so far (the budget's cost estimate)
        self._deadline = float("inf")  # when the round's rollouts stop (with a budget)
        self.options = {"max_searches": max_searches, "rank": rank}
        self.prioritized = lambda env: TaskPrioritized(env, **self.options)
        self.base = base or self.prioritized
        if not isinstance(planner, bool):
            raise ValueError(f"planner={planner!r}: true or false")
        # Rollouts by the base and by the planner too (a second base heuristic; module doc).
        self.bases = (self.base, self.prioritized) if planner and base else (self.base,)
        self.guide = None if guide is None else guide(self.env, seed)
        self._guide_scores = None  # the guide's scores of the round's observations, once
        if self.guide is not None and not hasattr(self.guide, "scores"):
            raise ValueError(f"guide={guide!r}: a trained task-level model's policy (a run "
                             "directory), which scores every crane's actions")  # fmt: skip
        self.rollouts = 0  # finished copies so far (its cost)
        # The last round's search values: (the first idle crane's agent, {its action: the
        # makespan its copy finished at}), None when the round compared nothing; imitation
        # with soft targets reads them (multicrane.training.soft_targets).
        self.values: tuple[str, dict[int, int]] | None = None
        self.expected: int | None = None  # the last round's pick: the makespan of its copy

    def __call__(self, observations) -> dict:
        began = time.perf_counter()
        env = self.env
        base = self.base(env)(observations)
        self._guide_scores = None
        joints = self._candidates(base, observations)
        self.values = self.expected = None
        if len(joints) == 1:
            return base
        self._longest = 0.0
        if self.budget is not None:
            self._deadline = began + self.budget - min(RESERVE, self.budget / 10)
        with collector_paused(self.budget is not None):
            scores = self._scores(joints, base_first=True)
            idle = env.mode.task_book().idle_cranes()
            agent = env.possible_agents[idle[0]]
            values: dict[int, int] = {}
            for joint, score in zip(joints, scores, strict=True):  # an action's best copy
                values[joint[agent]] = min(score, values.get(joint[agent], score))
            self.values = (agent, values)
            best = int(np.argmin(scores))  # argmin: the first of equals, the planner's
            joint, score = joints[best], scores[best]
            for i, crane in enumerate(idle[1 : self.cranes], 1):
                joint, score = self._improve(joint, score, crane, idle[:i], observations)
        self.expected = score
        return joint

    def _scores(self, joints: list[dict], base_first: bool = False) -> list[int]:
        """Each joint action's finishing makespan on a copy; with a budget, those that the
        time left might not cover are not played (``UNFINISHED``); ``base_first``: the first
        (the base's own) is always started (a rollout stops at the deadline)."""
        if self.budget is None:
            return [self._finish(joint) for joint in joints]
        scores: list[int] = []
        for k, joint in enumerate(joints):
            start = time.perf_counter()
            if (k or not base_first) and start + self._longest > self._deadline:
                scores.append(UNFINISHED)
                continue
            scores.append(self._finish(joint))
            self._longest = max(self._longest, time.perf_counter() - start)
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
        agent = env.possible_agents[idle[0]]
        out = [base]
        if self.guide is not None:
            own = self.guide(observations)
            if own != base:
                out.append(own)
        if len(self.bases) > 1:  # each base heuristic's own joint action
            own = self.prioritized(env)(observations)
            if own not in out:
                out.append(own)
        for action in self._order(idle[0], observations):
            joint = self._with(base, agent, action, fixed=())
            if joint not in out:
                out.append(joint)
        return out

    def _order(self, crane: int, observations) -> list[int]:
        """The crane's actions to try: its first ``candidates`` allowed tasks (``1 + p``) in
        the guide's order or nearest first, then waiting (``0``)."""
        book = self.env.mode.task_book()
        allowed = np.flatnonzero(book.allowed()[crane])
        if self.guide is None:
            order = allowed[np.argsort(book.static_len[crane][allowed], kind="stable")]
        else:
            if self._guide_scores is None:
                self._guide_scores = self.guide.scores(observations)
            agent = self.env.possible_agents[crane]
            scores = self._guide_scores[list(observations).index(agent)]
            order = allowed[np.argsort(-scores[1 + allowed], kind="stable")]
        return [1 + int(p) for p in order[: self.candidates]] + [0]

    def _with(self, joint: dict, agent: str, action: int, fixed) -> dict | None:
        """``joint`` with ``agent`` playing ``action``: another crane given a task of the same
        component or target waits, unless it is one of the ``fixed`` agents (their choices
        were made first): then None, the action is not open to ``agent``."""
        tasks = self.env.mode.task_book().tasks
        clash = tasks.conflicts(action - 1) if action else np.zeros(len(tasks), dtype=bool)
        out = dict(joint)
        for a, x in joint.items():
            if a != agent and x and clash[x - 1]:
                if a in fixed:
                    return None
                out[a] = 0
        out[agent] = action
        return out

    def _improve(self, joint: dict, score: int, crane: int, before: list[int],
                 observations) -> tuple[dict, int]:  # fmt: skip
        """Agent-by-agent rollout (``cranes`` > 1): another idle crane's alternatives to the
        best joint action so far, the cranes ``before`` it keeping their choices; the best
        joint action and its makespan (the incumbent on ties)."""
        agent = self.env.possible_agents[crane]
        fixed = {self.env.possible_agents[k] for k in before}
        alternatives: list[dict] = []
        for action in self._order(crane, observations):
            alt = self._with(joint, agent, action, fixed)
            if alt is not None and alt != joint and alt not in alternatives:
                alternatives.append(alt)
        scores = self._scores(alternatives)
        if scores and min(scores) < score:
            best = int(np.argmin(scores))
            return alternatives[best], scores[best]
        return joint, score

    def _finish(self, joint: dict) -> int:
        """The makespan of playing ``joint`` on a copy, then the base policy (with
        ``planner``: the shorter of that and the planner's finish of another copy)."""
        return min(self._finish_by(base, joint) for base in self.bases)

    def _finish_by(self, base, joint: dict) -> int:
        """The makespan of playing ``joint`` on a copy, then ``base`` (one rollout);
        ``UNFINISHED`` if it hits the step limit or runs past the round's deadline. A base
        that reads no observations (``reads_observations = False``: the prioritized rule)
        plays it with ``env.advance``, which builds none."""
        self.rollouts += 1
        env = rollout_copy(self.env)
        first = env.possible_agents[0]
        policy = base(env)
        blind = not getattr(policy, "reads_observations", True)  # a rule: no observations
        deadline, clock = self._deadline, time.perf_counter
        observations = {}
        while True:
            if blind:
                terminated, truncated = env.advance(joint)
            else:
                observations, _, terminations, truncations, _ = env.step(joint)
                terminated, truncated = terminations[first], truncations[first]
            if terminated:
                return env.sim.state.step_count
            if truncated or clock() > deadline:
                return UNFINISHED
            joint = policy(observations)


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
