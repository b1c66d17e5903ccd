"""Training checkpoints on disk: atomic saves, the previous good one kept, recovery on load.

A run directory holds ``checkpoint/`` (the newest complete checkpoint) and, after the second
save, ``checkpoint.prev/`` (the one before, kept until a newer one is complete). A save
writes ``checkpoint.tmp/`` (``steps.txt`` last: it marks the folder complete), then moves
``checkpoint/`` to ``checkpoint.prev/`` and ``checkpoint.tmp/`` to ``checkpoint/``.

Loading first *recovers*: if a save was cut between its steps (a complete
``checkpoint.tmp/`` newer than ``checkpoint/``, or ``checkpoint/`` missing beside a complete
``.tmp``/``.prev``/``.old``), the newest complete folder becomes ``checkpoint/``, with a
message. Then it loads; if the files cannot be read (a truncated ``state.pkl`` or
``model.zip``), the folder is moved aside as ``checkpoint.corrupt-<time>`` and the previous
good checkpoint is loaded instead, with a message; with none left, the run starts over, with
a message (the corrupt folder is kept). Nothing is dropped silently.
"""

from __future__ import annotations

import gzip
import pickle
import random
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import torch as th

from multicrane.files import aside_path
from multicrane.training.config import CHECKPOINT

TMP, PREV, OLD = CHECKPOINT + ".tmp", CHECKPOINT + ".prev", CHECKPOINT + ".old"
STEPS = "steps.txt"


def _rng_states(model) -> dict[str, Any]:
    return {
        "torch": th.get_rng_state(),
        "numpy": np.random.get_state(),  # noqa: NPY002 (SB3 draws from the global generator)
        "random": random.getstate(),
        "action_space": model.action_space.np_random.bit_generator.state,
    }


def _set_rng_states(model, states: dict[str, Any]) -> None:
    th.set_rng_state(states["torch"])
    np.random.set_state(states["numpy"])  # noqa: NPY002
    random.setstate(states["random"])
    model.action_space.np_random.bit_generator.state = states["action_space"]


def save_checkpoint(run_dir: Path, model, venv, progress: dict[str, Any]) -> None:
    """Write ``checkpoint/`` atomically, keeping the one before as ``checkpoint.prev/``."""
    final, tmp, prev = run_dir / CHECKPOINT, run_dir / TMP, run_dir / PREV
    shutil.rmtree(tmp, ignore_errors=True)
    tmp.mkdir()
    model.save(tmp / "model.zip")
    if getattr(model, "replay_buffer", None) is not None:
        with gzip.open(tmp / "replay_buffer.pkl.gz", "wb", compresslevel=1) as f:
            pickle.dump(model.replay_buffer, f, protocol=pickle.HIGHEST_PROTOCOL)
    state = {"venv": venv.get_state(), "rng": _rng_states(model), "progress": progress}
    (tmp / "state.pkl").write_bytes(pickle.dumps(state))
    (tmp / STEPS).write_text(f"{model.num_timesteps}\n")  # marks it complete
    if final.exists():
        shutil.rmtree(prev, ignore_errors=True)
        final.rename(prev)
    tmp.rename(final)
    shutil.rmtree(run_dir / OLD, ignore_errors=True)  # the layout before checkpoint.prev


def steps_of(folder: Path) -> int | None:
    """The step of a complete checkpoint folder, or None (missing or incomplete)."""
    try:
        return int((folder / STEPS).read_text().strip())
    except (OSError, ValueError):
        return None


def checkpoint_complete(run_dir: Path) -> bool:
    """True when the run has a complete checkpoint, or one that ``recover`` can restore."""
    return any(steps_of(run_dir / name) is not None for name in (CHECKPOINT, TMP, PREV, OLD))


def recover(run_dir: Path, log: Callable[[str], None]) -> None:
    """Make ``checkpoint/`` the newest complete checkpoint (a save cut short leaves it in
    ``checkpoint.tmp/``, or ``checkpoint/`` missing), saying so."""
    final = run_dir / CHECKPOINT
    current = steps_of(final)
    best, best_steps = None, current
    # checkpoint.prev/ is older than checkpoint/ by construction: only used without it.
    for name in (TMP, OLD) if current is not None else (TMP, OLD, PREV):
        steps = steps_of(run_dir / name)
        if steps is not None and (best_steps is None or steps > best_steps):
            best, best_steps = run_dir / name, steps
    if best is None:
        return
    if current is not None:
        shutil.rmtree(run_dir / PREV, ignore_errors=True)
        final.rename(run_dir / PREV)
    elif final.exists():  # an incomplete folder: nothing in it can be used
        shutil.rmtree(final)
    best.rename(final)
    was = f"at step {current}" if current is not None else "missing or incomplete"
    log(
        f"{run_dir}: recovered the checkpoint at step {best_steps} from {best.name} "
        f"(a save was cut short; {CHECKPOINT}/ was {was})"
    )


def _read(folder: Path, algo, venv):
    """The model and progress of one checkpoint folder; every file is read before anything
    is changed, so a failure leaves the environments as they were."""
    state = pickle.loads((folder / "state.pkl").read_bytes())
    buffer = None
    if (folder / "replay_buffer.pkl.gz").exists():
        with gzip.open(folder / "replay_buffer.pkl.gz", "rb") as f:
            buffer = pickle.load(f)
    # force_reset=False keeps the saved last observations: the copies continue, not restart.
    model = algo.cls.load(folder / "model.zip", env=venv, device="cpu", force_reset=False)
    venv.set_state(state["venv"])
    if buffer is not None:
        model.replay_buffer = buffer
    _set_rng_states(model, state["rng"])
    return model, state["progress"]


def load_checkpoint(run_dir: Path, algo, venv, log: Callable[[str], None] = print):
    """The model and progress of the newest readable checkpoint, with environments and
    generators restored to that moment; None when none is left (the run starts over).
    Recovers a cut save first; falls back from an unreadable checkpoint to the previous."""
    recover(run_dir, log)
    final, prev = run_dir / CHECKPOINT, run_dir / PREV
    while steps_of(final) is not None:
        steps = steps_of(final)
        try:
            return _read(final, algo, venv)
        except Exception as exc:  # noqa: BLE001 (truncated pickle or zip: any error)
            aside = aside_path(final)
            final.rename(aside)
            why = f"{type(exc).__name__}: {exc}"
            if steps_of(prev) is not None:
                prev.rename(final)
                log(
                    f"{run_dir}: the checkpoint at step {steps} is unreadable ({why}); moved "
                    f"to {aside.name}; falling back to the previous one at step {steps_of(final)}"
                )
            else:
                log(
                    f"{run_dir}: the checkpoint at step {steps} is unreadable ({why}); moved "
                    f"to {aside.name}; no previous checkpoint: the run starts over"
                )
    return None


def remove_checkpoints(run_dir: Path) -> None:
    """A finished run needs no checkpoint: remove every checkpoint folder (not set-asides)."""
    for name in (CHECKPOINT, TMP, PREV, OLD):
        shutil.rmtree(run_dir / name, ignore_errors=True)
