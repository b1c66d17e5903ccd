"""Expert iteration: the teacher's search run over the learned policy, distilled into it.

Imitation and DAgger copy a teacher, so the policy is at best as good as it. Expert
iteration (Anthony, Tian and Barber, "Thinking fast and slow with deep learning and tree
search", NeurIPS 2017) builds a better teacher from the policy itself: the look-ahead search
(``policies.lookahead``: a rollout algorithm, every candidate of a round finished on a copy
of the site) with the learned policy as its base policy, proposing the round's first
candidate and finishing every copy, in place of the prioritized planner. The base's own
choice is always a candidate, so the search expects to finish no later than the policy it
improves. Its episodes are distilled into the policy (``dagger.improve``), and the next
round searches over the better policy.

``PolicyPlanner`` is the learned set policy as a planner of such a search: greedy, the
cranes claiming tasks one after the other as deployed, and no network call in a round where
no crane may do anything but wait or go on (most rounds: cranes are busy carrying). A teacher
that can be guided has ``guided(base) -> make_teacher`` (``policies.lookahead.
LookaheadTeacher``; ``multicrane train --expert-iteration`` passes one, this package never
imports ``policies``).
"""

from __future__ import annotations

from collections.abc import Callable
from types import SimpleNamespace

from multicrane.training.config import ConfigError
from multicrane.training.model_policy import SetModelPolicy


def as_model(policy) -> SimpleNamespace:
    """What ``SetModelPolicy`` and ``evaluate_model`` read of a model, for a bare policy."""
    return SimpleNamespace(policy=policy, masked_policy=True)


class PolicyPlanner(SetModelPolicy):
    """A trained set policy (``SetPolicy``) as a greedy planner for ``env``: ``planner(
    observations) -> joint action``; observations that hold only the masks are read from the
    environment when the network is needed."""

    def __init__(self, policy, env):
        super().__init__(as_model(policy), env)

    def __call__(self, observations: dict) -> dict:
        agents = self.env.possible_agents
        masks = [observations[a]["action_mask"] for a in agents]
        if not any(mask[1:].any() for mask in masks):  # wait or go on: nothing to choose
            return dict.fromkeys(agents, 0)
        if "observation" not in observations[agents[0]]:
            rows, _ = self.env.mode.observe()
            observations = {a: {"observation": rows[k], "action_mask": masks[k]}
                            for k, a in enumerate(agents)}  # fmt: skip
        return super().__call__(observations)


def guided_teacher(make_teacher, policy) -> Callable:
    """The teacher's search over ``policy`` (``make_teacher.guided``); ``ConfigError`` when
    the teacher is not a search that can be guided."""
    guided = getattr(make_teacher, "guided", None)
    if guided is None:
        raise ConfigError(
            "expert_iteration: the teacher is not a search over a base policy "
            "(imitate='lookahead' with multicrane train, or policies.lookahead.LookaheadTeacher)"
        )
    return guided(lambda env: PolicyPlanner(policy, env))
