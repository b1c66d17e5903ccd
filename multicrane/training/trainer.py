"""Train one run: build the environments and model, checkpoint, resume, evaluate.

A run lives in a directory: ``config.json``; ``checkpoint/`` (model, environment copies,
random-generator states, and the replay buffer for DQN), written atomically at update
boundaries every ``checkpoint_every`` steps and when interrupted (SIGINT/SIGTERM, or
``stop_at``; kept with the previous one and recovered on resume, see
``multicrane.training.checkpoints``); ``tb/`` (TensorBoard); ``run.lock`` while a process
trains it (``multicrane.training.run_lock``); and, once finished, ``model.zip`` and ``result.json``.

Resuming loads the checkpoint and continues exactly where it stopped: the environment copies,
the last observations and every random generator come back, so a run interrupted and
resumed learns the same parameters as an uninterrupted one (tested), and no step is lost or
repeated. A checkpoint is only taken between updates (PPO/A2C: before a rollout; DQN: before
an environment step), where the state is whole.
"""

from __future__ import annotations

import json
import platform
import signal
import time
from contextlib import contextmanager
from functools import partial
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
import torch as th
from stable_baselines3.common.callbacks import BaseCallback

from multicrane.files import write_json_atomic
from multicrane.training.algorithms import algorithm, hyperparameters, make_model, round_gamma
from multicrane.training.checkpoints import (
    checkpoint_complete,
    load_checkpoint,
    remove_checkpoints,
    save_checkpoint,
)
from multicrane.training.clone_term import with_cloning
from multicrane.training.config import ConfigError, TrainConfig
from multicrane.training.policy_change import checked_max_kl, with_policy_change
from multicrane.training.run_envs import (
    evaluate_model,
    make_vec_env,
    paper_env,  # noqa: F401 (imported from here)
)
from multicrane.training.run_lock import RunLock
from multicrane.training.set_training import make_set_model, set_hyperparameters
from multicrane.training.warm_start import warm_start

RESULT = "result.json"
KEPT_PROGRESS = ("init_from", "imitation", "best", "clone", "time_up")  # into result.json
BEST = "best.zip"  # keep_best: the model of the best validation point so far
PACKAGES = (
    "multicrane",
    "numpy",
    "gymnasium",
    "pettingzoo",
    "torch",
    "stable-baselines3",
    "sb3-contrib",
    "supersuit",
)


# -- checkpoints -------------------------------------------------------------------------------


# save_checkpoint, load_checkpoint and recovery: multicrane.training.checkpoints


# -- the run -----------------------------------------------------------------------------------


class _Interrupt:
    """The first SIGINT/SIGTERM asks the run to stop at the next update boundary (with a
    checkpoint); a second SIGINT stops at once."""

    def __init__(self) -> None:
        self.requested = False

    def __call__(self, signum, frame) -> None:
        if self.requested and signum == signal.SIGINT:
            raise KeyboardInterrupt
        self.requested = True

    @contextmanager
    def installed(self):
        previous = {}
        try:
            for sig in (signal.SIGINT, signal.SIGTERM):
                previous[sig] = signal.signal(sig, self)
        except ValueError:  # not the main thread: no signal handling
            pass
        try:
            yield self
        finally:
            for sig, handler in previous.items():
                signal.signal(sig, handler)


class _RunMonitor(BaseCallback):
    """Evaluations for the learning curve, checkpoints, interruption and the progress bar;
    all at update boundaries (``_on_rollout_start``)."""

    def __init__(self, run, stop_at: int | None, interrupt: _Interrupt, progress_bar: bool):
        super().__init__()
        self.run = run
        self.stop_at = stop_at
        self.interrupt = interrupt
        self.progress_bar = progress_bar
        self.stopping = False
        self.stopped_at: int | None = None
        self.bar = None

    def _on_training_start(self) -> None:
        if self.progress_bar:
            from tqdm.auto import tqdm

            self.bar = tqdm(
                total=self.run.cfg.total_steps,
                initial=self.model.num_timesteps,
                unit="step",
                desc=self.run.cfg.name,
                dynamic_ncols=True,
            )

    def _on_rollout_start(self) -> None:
        run, steps = self.run, self.model.num_timesteps
        if self.stopping:
            return
        if run.cfg.eval_every and steps >= run.progress["next_eval"]:
            run.evaluate_point()
            run.progress["next_eval"] = steps + run.cfg.eval_every
        due = run.cfg.checkpoint_every and steps >= run.progress["next_checkpoint"]
        stop = self.interrupt.requested or (self.stop_at is not None and steps >= self.stop_at)
        if stop or (due and steps < run.cfg.total_steps):
            if due:
                run.progress["next_checkpoint"] = steps + run.cfg.checkpoint_every
            run.checkpoint()
        if stop:
            self.stopping, self.stopped_at = True, steps
        elif run.cfg.time_limit is not None and run.elapsed() >= run.cfg.time_limit:
            run.progress["time_up"] = steps  # ``_on_step`` ends learn; the run finishes

    def _on_step(self) -> bool:
        if self.bar is not None:
            self.bar.update(self.model.num_timesteps - self.bar.n)
        return not (self.stopping or "time_up" in self.run.progress)

    def _on_training_end(self) -> None:
        if self.bar is not None:
            self.bar.close()


class Run:
    """One training run in its directory; see the module doc. ``teacher``: the policy factory
    of ``cfg.imitate`` (``make_teacher(env, seed)``, e.g. ``policies.factory(name)``)."""

    def __init__(self, cfg: TrainConfig, run_dir: Path, log=print, teacher=None):
        self.cfg = cfg
        self.dir = Path(run_dir)
        self.log = log
        self.teacher = teacher
        if cfg.imitate is not None and teacher is None:
            raise ConfigError(
                f"imitate={cfg.imitate!r}: pass its policy as teacher= "
                f"(policies.factory({cfg.imitate!r}); multicrane train does)"
            )
        self.algo = algorithm(cfg.algo, cfg.paper)
        if cfg.policy == "set":
            self.params = set_hyperparameters(cfg.hyperparams)
        else:
            self.params = hyperparameters(
                self.algo, cfg.scenario if cfg.paper else None, cfg.hyperparams
            )
        self.params = round_gamma(self.params, cfg.decisions, cfg.reward, cfg.hyperparams)
        self.max_policy_kl = checked_max_kl(self.params.pop("max_policy_kl", None), self.algo)
        self.progress: dict[str, Any] = {}
        self.model = None
        self.venv = None
        self._session_start = 0.0

    # -- bookkeeping -----------------------------------------------------------------------

    def _claim_directory(self) -> dict | None:
        """Create the directory or check it belongs to this configuration; the finished
        result when there is one."""
        self.dir.mkdir(parents=True, exist_ok=True)
        path = self.dir / "config.json"
        if path.exists():
            stored = TrainConfig.load(path)
            diff = stored.differences(self.cfg)
            if diff:
                raise ConfigError(
                    f"{self.dir} holds a run with another configuration ({'; '.join(diff)}): "
                    "use another directory, or delete it to start over"
                )
        else:
            self.cfg.save(path)
        result = self.dir / RESULT
        if result.exists():
            try:
                return json.loads(result.read_text())
            except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
                aside = result.with_name(f"{RESULT}.unreadable")
                result.replace(aside)
                self.log(f"{result}: unreadable ({exc}); moved to {aside.name}, run again")
        return None

    def elapsed(self) -> float:
        return self.progress["seconds"] + time.perf_counter() - self._session_start

    def checkpoint(self) -> None:
        self.progress["seconds"] = self.elapsed()
        self._session_start = time.perf_counter()
        save_checkpoint(self.dir, self.model, self.venv, self.progress)

    def evaluate_point(self) -> None:
        _, summary = evaluate_model(
            self.model, self.cfg, self.algo, self.cfg.eval_episodes, optimal=False
        )
        point = {
            "step": int(self.model.num_timesteps),
            "return_mean": summary["return_mean"],
            "return_sem": summary["return_sem"],
            "success_rate": summary["success_rate"],
            "steps_mean": summary["steps_mean"],
            "train_return_mean": _train_return(self.model),
            "seconds": round(self.elapsed(), 3),
        }
        if self.cfg.keep_best:
            self._validate(point)
        self.progress["curve"].append(point)
        self.model.logger.record("eval/return_mean", point["return_mean"])
        self.model.logger.record("eval/success_rate", point["success_rate"])

    def _validate(self, point: dict) -> None:
        """``keep_best``: the point's validation return; a better one saves ``best.zip``."""
        _, val = evaluate_model(self.model, self.cfg, self.algo, self.cfg.eval_episodes,
                                optimal=False, validation=True)  # fmt: skip
        point["validation_return_mean"] = val["return_mean"]
        point["validation_success_rate"] = val["success_rate"]
        best = self.progress.get("best")
        if best is None or val["return_mean"] > best["validation_return_mean"]:
            tmp = self.dir / BEST.replace(".zip", ".tmp.zip")
            self.model.save(tmp)
            tmp.replace(self.dir / BEST)
            self.progress["best"] = {"step": point["step"],
                                     "validation_return_mean": val["return_mean"]}  # fmt: skip

    # -- training --------------------------------------------------------------------------

    def execute(self, progress_bar: bool = False, stop_at: int | None = None) -> dict | None:
        """Train (or resume) to the budget; the result, or None when stopped early. Holds
        the directory's lock throughout (``RunLockedError`` when another process has it)."""
        with RunLock(self.dir, self.log):
            return self._execute(progress_bar, stop_at)

    def _execute(self, progress_bar: bool, stop_at: int | None) -> dict | None:
        done = self._claim_directory()
        if done is not None:
            return done
        th.set_num_threads(self.cfg.torch_threads)
        self.venv = make_vec_env(self.cfg, self.algo, self.params)
        loaded = None
        if checkpoint_complete(self.dir):  # a cut save or a corrupt checkpoint: see the log
            loaded = load_checkpoint(self.dir, self.algo, self.venv, self.log)
            if loaded is None:  # none readable: start over on fresh environment copies
                self.venv = make_vec_env(self.cfg, self.algo, self.params)
        fresh = loaded is None
        if fresh:
            make = make_set_model if self.cfg.policy == "set" else partial(make_model, self.algo)
            self.model = make(self.venv, self.cfg.seed, self.params, str(self.dir / "tb"))
            self.progress = {
                "next_eval": 0,
                "next_checkpoint": self.cfg.checkpoint_every,
                "curve": [],
                "seconds": 0.0,
                "sessions": 1,
            }
            if self.cfg.init_from is not None:
                self.progress["init_from"] = warm_start(self.model, self.cfg, self.log)
            if self.cfg.imitate is not None:
                from multicrane.training.teaching import imitate

                self.progress["imitation"] = imitate(
                    self.cfg, self.params, self.model.policy, self.teacher, self.log
                )
        else:
            self.model, self.progress = loaded
            self.progress["sessions"] += 1
            self.log(f"{self.cfg.name}: resuming at step {self.model.num_timesteps}")
        if self.cfg.policy == "set":  # the cranes of a copy claim in turn, as deployed
            self.model.policy.claim_rows = self.venv.n_agents
        self._session_start = time.perf_counter()
        interrupt = _Interrupt()
        monitor = _RunMonitor(self, stop_at, interrupt, progress_bar)
        callback = with_policy_change(self.model, with_cloning(self, monitor),
                                      self.max_policy_kl)  # fmt: skip
        remaining = self.cfg.total_steps - self.model.num_timesteps
        with interrupt.installed():
            if remaining > 0:
                self.model.learn(
                    remaining,
                    callback=callback,
                    reset_num_timesteps=fresh,
                    tb_log_name=self.cfg.algo,
                )
        if monitor.stopping:
            self.log(f"{self.cfg.name}: stopped at step {monitor.stopped_at}; resume later")
            self.venv.close()
            return None
        return self._finish()

    def _finish(self) -> dict:
        train_seconds = self.elapsed()
        if self.cfg.eval_every and (
            not self.progress["curve"]
            or self.progress["curve"][-1]["step"] != self.model.num_timesteps
        ):
            self.evaluate_point()
        if self.cfg.keep_best:  # the final model is the best validation point's
            best = self.algo.cls.load(self.dir / BEST, device="cpu")
            self.model.policy.load_state_dict(best.policy.state_dict())
        self.model.save(self.dir / "model.zip")
        start = time.perf_counter()
        episodes, summary = evaluate_model(
            self.model, self.cfg, self.algo, self.cfg.final_eval_episodes, optimal=self.cfg.paper
        )
        result = {
            "config": self.cfg.to_dict(),
            "algorithm": self.algo.label,
            "hyperparameters": _jsonable({**self.params, "max_policy_kl": self.max_policy_kl}),
            "steps": int(self.model.num_timesteps),
            "final": summary,
            "final_episodes": episodes,
            "final_metric": (
                f"mean return of the trained policy (greedy actions) over "
                f"{self.cfg.final_eval_episodes} evaluation episodes, reset seeds 1000000.."
            ),
            "train_return_mean": _train_return(self.model),
            "curve": self.progress["curve"],
            "train_seconds": round(train_seconds, 3),
            "eval_seconds": round(time.perf_counter() - start, 3),
            "steps_per_second": round(self.model.num_timesteps / max(train_seconds, 1e-9), 1),
            "sessions": self.progress["sessions"],
            **{k: self.progress[k] for k in KEPT_PROGRESS if k in self.progress},
            **_curriculum(self.venv),
            "versions": versions(),
            "python": platform.python_version(),
        }
        write_json_atomic(self.dir / RESULT, result)
        remove_checkpoints(self.dir)
        self.venv.close()
        return result


def train(
    cfg: TrainConfig,
    run_dir: str | Path,
    *,
    progress_bar: bool = False,
    stop_at: int | None = None,
    log=print,
    teacher=None,
) -> dict | None:
    """Train ``cfg`` in ``run_dir`` (resuming what is there); the result dict (also in
    ``result.json``), or None when interrupted or stopped at ``stop_at`` steps. ``teacher``:
    the policy factory that ``cfg.imitate`` names (see ``Run``)."""
    run = Run(cfg, Path(run_dir), log=log, teacher=teacher)
    return run.execute(progress_bar=progress_bar, stop_at=stop_at)


def _curriculum(venv) -> dict:
    sites = getattr(venv, "sites", None)
    return {"curriculum": sites.describe()} if sites is not None else {}


def _train_return(model) -> float | None:
    buf = model.ep_info_buffer
    return float(np.mean([e["r"] for e in buf])) if buf else None


def _jsonable(params: dict) -> dict:
    return json.loads(json.dumps(params, default=lambda o: getattr(o, "__name__", repr(o))))


def versions() -> dict[str, str]:
    out = {}
    for name in PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out
