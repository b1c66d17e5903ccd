"""Rounds after imitation: DAgger, then expert iteration, each round refitting the policy.

A cloned policy only saw the teacher's states; its own small mistakes lead it to states the
teacher never showed, where it is poorly fitted (Ross, Gordon and Bagnell, "A reduction of
imitation learning and structured prediction to no-regret online learning", AISTATS 2011).
A DAgger round plays ``round_episodes`` episodes of the current policy as it is deployed
(the cranes of a round claim tasks one after the other, a wait loop is broken; even copies
act greedily, odd copies sample from the policy so that a site whose episodes are all the
same still shows other states), asks the teacher for its joint action in every round they
reach (``imitation.demonstrate`` with a learner), adds those rows to all earlier ones
(never dropping any) and fits the policy again on the whole set. An expert-iteration round
(``multicrane.training.expert_iteration``) lets the teacher's search over the policy play
and label its own episodes instead (a state an earlier expert-iteration round labelled
keeps only the newest label). ``improve`` runs ``dagger`` rounds, then
``expert_iteration`` rounds; after each, the greedy policy plays the run's validation
episodes (``eval_episodes``, reset seeds 2,000,000 ...) and the policy of the best round
(the imitated one, or a warm start's, included) is the one kept.

A round's rows depend on the run's seed (its policy played or guided them): with
``imitate_demos`` they are kept beside that file, one file per seed and round
(``FILE-dagger-s{seed}-r{round}.npz``, ``FILE-expit-s{seed}-r{round}.npz``), so that a
rerun, or a run with more rounds, reads them instead of asking the teacher again.
"""

from __future__ import annotations

import copy
import hashlib
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import torch as th

from multicrane.training.expert_iteration import as_model, guided_teacher
from multicrane.training.imitation import Demonstrations, DemonstrationsError, clone, demonstrate
from multicrane.training.imitation import load as load_demos
from multicrane.training.imitation import save as save_demos
from multicrane.training.model_policy import SetModelPolicy

ROUND_STREAM = 3  # a round's copies' seeds: [run seed, ROUND_STREAM, kind, round]
ROUND_KINDS = ("dagger", "expit")


class PaddedLearner(SetModelPolicy):
    """The deployed set policy (``SetModelPolicy``: exclusive claims, wait-loop breaking) on
    rows a ``SetVecEnv`` already padded: ``learner(rows, masks) -> actions``."""

    def __init__(self, policy, env, deterministic: bool = True):
        super().__init__(as_model(policy), env, deterministic)

    def __call__(self, rows: np.ndarray, masks: np.ndarray) -> np.ndarray:
        joint = super().__call__({a: (rows[k], masks[k]) for k, a in enumerate(self.agents)})
        return np.array(list(joint.values()), dtype=np.int64)

    @property
    def agents(self) -> list[str]:
        return self.env.possible_agents

    def _inputs(self, observations: dict) -> tuple[np.ndarray, np.ndarray]:
        rows = list(observations.values())
        return np.stack([r[0] for r in rows]), np.stack([r[1] for r in rows]).astype(bool)


def learner_of(policy) -> Callable:
    """``make_learner(env, copy)`` for ``demonstrate``: greedy on even copies, sampling on odd
    ones."""
    return lambda env, c: PaddedLearner(policy, env, deterministic=c % 2 == 0)


def round_seed(run_seed: int, tag: str, round_: int) -> int:
    """The seed of a round's copies: independent of the training and demonstration copies'
    seeds and of the other rounds'."""
    kind = ROUND_KINDS.index(tag)
    sequence = np.random.SeedSequence([int(run_seed), ROUND_STREAM, kind, int(round_)])
    return int(sequence.generate_state(1)[0])


def merge(a: Demonstrations, b: Demonstrations, newest: bool = False) -> Demonstrations:
    """Every row of ``a`` then every row of ``b`` (values: NaN for rows without them).
    ``newest``: leave out the rows of ``a`` whose observation is also one of ``b``'s (a later
    search labels that state again, and its label is the one to fit)."""
    keep = slice(None)
    if newest:
        seen = {_digest(row) for row in b.observations}
        keep = np.array([_digest(row) not in seen for row in a.observations], dtype=bool)
    arrays = {name: np.concatenate([getattr(a, name)[keep], getattr(b, name)])
              for name in ("observations", "masks", "actions", "returns")}  # fmt: skip
    if a.values is not None or b.values is not None:
        arrays["values"] = np.concatenate([_values(a)[keep], _values(b)])
    return Demonstrations(**arrays, makespans=a.makespans + b.makespans)


def _digest(row: np.ndarray) -> bytes:
    """A 128-bit digest of an observation row (rows are kilobytes; a set of digests is small)."""
    return hashlib.blake2b(np.ascontiguousarray(row).data, digest_size=16).digest()


def _values(demos: Demonstrations) -> np.ndarray:
    if demos.values is not None:
        return demos.values
    return np.full(demos.masks.shape, np.nan, dtype=np.float32)


def rounds_file(demos_path: str | None, tag: str, seed: int, round_: int) -> Path | None:
    """Where a round of run seed ``seed`` keeps its labelled rows (None: nowhere)."""
    if demos_path is None:
        return None
    path = Path(demos_path)
    return path.with_name(f"{path.stem}-{tag}-s{seed}-r{round_}{path.suffix or '.npz'}")


def validate(policy, cfg) -> dict:
    """The greedy policy on the run's validation episodes: mean makespan and success."""
    from multicrane.training.algorithms import algorithm
    from multicrane.training.run_envs import evaluate_model

    algo = algorithm(cfg.algo, cfg.paper)
    _, summary = evaluate_model(as_model(policy), cfg, algo, cfg.eval_episodes, optimal=False,
                                validation=True)  # fmt: skip
    return {"makespan_mean": summary["steps_mean"], "success_rate": summary["success_rate"],
            "return_mean": summary["return_mean"]}  # fmt: skip


def _better(a: dict, b: dict) -> bool:
    return (a["success_rate"], a["return_mean"]) > (b["success_rate"], b["return_mean"])


def label_round(cfg, params: dict, make_teacher: Callable, meta: dict, tag: str, round_: int,
                make_learner: Callable | None = None, log=print) -> Demonstrations:  # fmt: skip
    """Round ``round_``'s labelled rows (``tag``: ``"dagger"`` or ``"expit"``): read from its
    file, or played now (by ``make_learner``'s policy, else by the teacher) and labelled."""
    from multicrane.training.run_envs import shaping_gamma
    from multicrane.training.set_training import SET_COPIES, make_set_vec_env

    path = rounds_file(cfg.imitate_demos, tag, cfg.seed, round_)
    # What the policy that played or guided the round depends on, besides ``meta``'s setting.
    meta = {**meta, f"{tag}_round": round_, "learner_seed": cfg.seed,
            "episodes": cfg.round_episodes, "epochs": cfg.imitate_epochs,
            "dagger_rounds_before": cfg.dagger if tag == "expit" else round_ - 1,
            "policy_kwargs": params.get("policy_kwargs")}  # fmt: skip
    if cfg.imitate_stop is not None:  # older round files (made without it) stay readable
        meta["stop"] = cfg.imitate_stop
    if path is not None and path.exists():
        try:
            return load_demos(path, meta)
        except DemonstrationsError as exc:
            log(f"{cfg.name}: {exc}; labelling again")
    venv = make_set_vec_env(cfg, cfg.n_envs or SET_COPIES, shaping_gamma(cfg, params), workers=1)
    seed = round_seed(cfg.seed, tag, round_)
    venv.seed(seed)
    th.manual_seed(seed)  # the sampling copies' draws
    labelled = demonstrate(venv, make_teacher, cfg.round_episodes, params["gamma"],
                           make_learner=make_learner, values="values" in meta)  # fmt: skip
    venv.close()
    if path is not None:
        save_demos(labelled, path, meta)
    return labelled


def improve(cfg, params: dict, policy, make_teacher: Callable, demos: Demonstrations,
            meta: dict, log=print) -> dict:  # fmt: skip
    """``cfg.dagger`` DAgger rounds, then ``cfg.expert_iteration`` rounds of expert iteration
    (``multicrane.training.expert_iteration``), on ``policy`` (already fitted to ``demos``,
    whose ``meta`` ``teaching.imitate`` made; ``demos`` None: a warm start's trained policy,
    with no first rows); the summary of every round. DAgger refits
    on every row so far; expert iteration on the rows of its own rounds (the guided search
    is a better teacher than the first one), each round starting from the best policy, a
    state that a later round labels again keeping only that round's label (``merge``'s
    ``newest``: two searches over different policies choose differently at the same early
    states, and fitting both leaves the policy between their episodes)."""
    start = time.perf_counter()
    first = "imitation" if demos is not None else "init"  # None: a warm start's policy
    best = {"round": first, **validate(policy, cfg)}
    kept = copy.deepcopy(policy.state_dict())
    rounds = [dict(best)]
    log(f"{cfg.name}: {first} policy, validation makespan {best['makespan_mean']:.1f}")
    schedule = [("dagger", r) for r in range(1, cfg.dagger + 1)]
    schedule += [("expit", r) for r in range(1, cfg.expert_iteration + 1)]
    expert = None
    for tag, round_ in schedule:
        tick = time.perf_counter()
        if tag == "dagger":
            labelled = label_round(cfg, params, make_teacher, meta, tag, round_,
                                   learner_of(policy), log)  # fmt: skip
            data = demos = labelled if demos is None else merge(demos, labelled)
        else:
            policy.load_state_dict(kept)
            teacher = guided_teacher(make_teacher, policy)
            labelled = label_round(cfg, params, teacher, meta, tag, round_, log=log)
            data = expert = labelled if expert is None else merge(expert, labelled, newest=True)
        history = clone(policy, data, cfg.imitate_epochs, seed=cfg.seed + len(rounds),
                        soft=cfg.imitate_soft, stop_at=cfg.imitate_stop)  # fmt: skip
        point = {"round": f"{tag}-{round_}", **validate(policy, cfg), "rows": len(data),
                 "played": "learner" if tag == "dagger" else "teacher",
                 "played_makespan_mean": _mean(labelled.makespans),
                 "agreement": history[-1]["agreement"], "epochs_run": len(history),
                 "seconds": round(time.perf_counter() - tick, 3)}  # fmt: skip
        rounds.append(point)
        log(f"{cfg.name}: {tag} round {round_}: {len(data)} rows, the {point['played']} "
            f"played {point['played_makespan_mean']}, validation makespan "
            f"{point['makespan_mean']:.1f} ({point['seconds']:.0f} s)")  # fmt: skip
        if _better(point, best):
            best, kept = point, copy.deepcopy(policy.state_dict())
    policy.load_state_dict(kept)
    return {"rounds": rounds, "kept_round": best["round"],
            "seconds": round(time.perf_counter() - start, 3)}  # fmt: skip


def _mean(makespans: list) -> float | None:
    finished = [m for m in makespans if m is not None]
    return round(float(np.mean(finished)), 3) if finished else None
