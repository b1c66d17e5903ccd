"""The teaching step of a training run: imitation of a teacher, then its improvement rounds.

``imitate`` runs when a fresh run has ``TrainConfig.imitate``: demonstrations on copies of
the run's environments that draw other reset seeds than its training copies (or read from
``imitate_demos``), then ``imitation.clone``; then ``dagger`` DAgger rounds and
``expert_iteration`` rounds (``multicrane.training.dagger``), if asked for. A warm start
(``TrainConfig.init_from``, ``multicrane.training.warm_start``) has a trained policy
already: it runs only the rounds. It returns a summary for ``result.json``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from multicrane.training.dagger import improve
from multicrane.training.imitation import clone, demonstrate, demonstration_seed, load, save
from multicrane.training.soft_targets import valued_rows
from multicrane.training.warm_start import weights_digest


def imitate(cfg, params: dict, policy, make_teacher: Callable, log=print) -> dict:
    """The teaching step of a fresh training run (``cfg`` a ``TrainConfig`` with
    ``imitate``; ``params`` its learner settings): fit ``policy`` and return the summary.
    A warm start (``cfg.init_from``) skips the first imitation: only the rounds run, on the
    policy it loaded."""
    from multicrane.training.algorithms import algorithm
    from multicrane.training.run_envs import make_vec_env, shaping_gamma
    from multicrane.training.set_training import SET_COPIES, make_set_vec_env

    start = time.perf_counter()
    gamma = shaping_gamma(cfg, params)
    if cfg.policy == "set":  # in this process: the teacher reads the copies' sites
        venv = make_set_vec_env(cfg, cfg.n_envs or SET_COPIES, gamma, workers=1)
    else:
        venv = make_vec_env(cfg, algorithm(cfg.algo, cfg.paper), params)
    limits = venv.limits.to_dict() if cfg.policy == "set" else None
    meta = {"teacher": cfg.imitate, "scenario": cfg.scenario, "cranes": cfg.n_cranes,
            "decisions": cfg.decisions, "curriculum": cfg.curriculum, "limits": limits,
            "episodes": cfg.imitate_episodes, "reward": cfg.reward, "events": cfg.events,
            "max_steps": cfg.max_steps, "shaping": cfg.shaping_weight, "shaping_gamma": gamma,
            "gamma": params["gamma"], "seed": demonstration_seed(cfg.seed),
            "claims": "exclusive"}  # fmt: skip
    if cfg.reward_scale != "none":  # the rows' returns are in the scaled reward
        meta["reward_scale"] = cfg.reward_scale
    if cfg.imitate_soft is not None:  # the rows also keep the teacher's values (soft targets)
        meta["values"] = "candidate makespans"
    if cfg.init_from is None:
        demos, summary = _first_imitation(cfg, params, policy, make_teacher, venv, meta, log)
    else:  # the rounds' rows depend on the policy it starts from
        meta["init_weights"] = weights_digest(policy)
        demos, summary = None, {"teacher": cfg.imitate, "init_from": cfg.init_from}
    venv.close()
    if cfg.dagger or cfg.expert_iteration:
        summary["rounds"] = improve(cfg, params, policy, make_teacher, demos, meta, log)
    summary["seconds"] = round(time.perf_counter() - start, 3)
    return summary


def progress_log(label: str, episodes: int, log=print) -> Callable[[int], None]:
    """A ``demonstrate`` progress callback that logs every tenth of ``episodes`` (the last
    included) with the elapsed time, so a long teacher run shows that it moves."""
    start = time.perf_counter()
    step = max(1, episodes // 10)

    def report(finished: int) -> None:
        if finished <= episodes and (finished % step == 0 or finished == episodes):
            log(f"{label}: {finished}/{episodes} teacher episodes "
                f"({time.perf_counter() - start:.0f} s)")  # fmt: skip

    return report


def _first_imitation(cfg, params: dict, policy, make_teacher: Callable, venv, meta: dict,
                     log=print) -> tuple:  # fmt: skip
    """The teacher's demonstrations (read from ``cfg.imitate_demos`` or played on ``venv``)
    and ``policy`` fitted to them: (the demonstrations, the summary)."""
    start = time.perf_counter()
    path = cfg.imitate_demos
    if path is not None and Path(path).exists():
        demos = load(path, meta)
        log(f"{cfg.name}: demonstrations from {path}")
    else:
        venv.seed(meta["seed"])
        progress = progress_log(f"{cfg.name}: {cfg.imitate}", cfg.imitate_episodes, log)
        demos = demonstrate(venv, make_teacher, cfg.imitate_episodes, params["gamma"],
                            values="values" in meta, progress=progress)  # fmt: skip
        if path is not None and not save(demos, path, meta, exclusive=True):
            # Another run of the same setting wrote the file while this one played: clone
            # the file's episodes, so that every run that names the file clones the same ones.
            demos = load(path, meta)
            log(f"{cfg.name}: {path} was written by another run meanwhile: cloning its "
                "demonstrations instead of this run's")  # fmt: skip
    collected = time.perf_counter() - start
    history = clone(policy, demos, cfg.imitate_epochs, seed=cfg.seed, soft=cfg.imitate_soft,
                    stop_at=cfg.imitate_stop)
    finished = [m for m in demos.makespans if m is not None]
    summary = {
        "teacher": cfg.imitate,
        "demonstrations": path,
        "episodes": len(demos.makespans),
        "teacher_makespan_mean": float(np.mean(finished)) if finished else None,
        "teacher_finished": len(finished),
        "rows": len(demos),
        "decision_rows": int(demos.decisions.sum()),
        "soft_tau": cfg.imitate_soft,
        "valued_rows": (
            None if demos.values is None else int(valued_rows(demos.values, demos.actions).sum())
        ),
        "history": history,
        "epochs_run": len(history),
        "agreement": history[-1]["agreement"],
        "collect_seconds": round(collected, 3),
    }
    log(
        f"{cfg.name}: imitated {cfg.imitate} ({summary['episodes']} episodes, "
        f"{summary['decision_rows']} decisions; greedy agreement "
        f"{summary['agreement']:.1%}) in {time.perf_counter() - start:.0f} s"
    )
    return demos, summary
