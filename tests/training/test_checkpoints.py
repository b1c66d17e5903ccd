"""Checkpoint recovery (issue 20): a save cut between its steps, a truncated ``state.pkl`` or
``model.zip``; each resumes from the newest good checkpoint and says so.

Before the fix a standalone ``train`` that died between writing ``checkpoint.tmp`` and renaming
it restarted at step 0 without a word, and a truncated ``state.pkl`` gave a bare
``UnpicklingError``. A resumed run must still learn exactly what an uninterrupted one does.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

pytest.importorskip("stable_baselines3")

import torch as th  # noqa: E402

from multicrane.training import TrainConfig, train  # noqa: E402
from multicrane.training.model_policy import load_run  # noqa: E402

PPO_HP = {"n_steps": 64, "batch_size": 64, "n_epochs": 2}


def cfg(**changes) -> TrainConfig:
    kw = dict(
        scenario="E1S1",
        algo="ppo",
        total_steps=512,
        n_envs=2,
        hyperparams=dict(PPO_HP),
        eval_episodes=1,
        checkpoint_every=128,  # one checkpoint per update (2 copies x 64 steps)
        eval_every=0,
    )
    kw.update(changes)
    return TrainConfig(**kw)


pytestmark = pytest.mark.usefixtures("one_torch_thread")


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> dict:
    """The uninterrupted run's parameters."""
    th.set_num_threads(1)
    run_dir = tmp_path_factory.mktemp("ref") / "run"
    train(cfg(), run_dir, log=lambda *_: None)
    model, _ = load_run(run_dir)
    return {k: v.clone() for k, v in model.policy.state_dict().items()}


def _stopped_run(tmp_path: Path, stop_at: int = 384) -> Path:
    """A run stopped at ``stop_at`` steps with ``checkpoint/`` and ``checkpoint.prev/``."""
    run_dir = tmp_path / "run"
    assert train(cfg(), run_dir, stop_at=stop_at, log=lambda *_: None) is None
    assert (run_dir / "checkpoint" / "steps.txt").read_text().strip() == str(stop_at)
    assert (run_dir / "checkpoint.prev" / "steps.txt").is_file()  # the previous one is kept
    return run_dir


def _resume(run_dir: Path, reference: dict) -> list[str]:
    messages: list[str] = []
    result = train(cfg(), run_dir, log=messages.append)
    assert result is not None and result["steps"] == 512
    model, _ = load_run(run_dir)
    state = model.policy.state_dict()
    assert all(th.equal(state[k], reference[k]) for k in reference), "not the same parameters"
    assert not any(run_dir.glob("checkpoint.prev")) and not (run_dir / "checkpoint").exists()
    return messages


def _steps(folder: Path) -> int:
    return int((folder / "steps.txt").read_text())


def test_stranded_tmp_is_recovered(tmp_path, reference):
    """Died after the new checkpoint was complete, before its renames: checkpoint.tmp/ is
    newer than checkpoint/ (or checkpoint/ is gone). The run resumes from the .tmp one."""
    run_dir = _stopped_run(tmp_path)
    shutil.copytree(run_dir / "checkpoint", run_dir / "checkpoint.tmp")
    shutil.rmtree(run_dir / "checkpoint")
    (run_dir / "checkpoint.prev").rename(run_dir / "checkpoint")  # the older one
    messages = _resume(run_dir, reference)
    assert any("recovered the checkpoint at step 384 from checkpoint.tmp" in m for m in messages)
    assert any("resuming at step 384" in m for m in messages)


def test_only_a_stranded_tmp_standalone(tmp_path, reference):
    """The issue's case: checkpoint/ missing, a complete checkpoint.tmp/ left: before, the
    run restarted at step 0 without a word."""
    run_dir = _stopped_run(tmp_path)
    shutil.rmtree(run_dir / "checkpoint.prev")
    (run_dir / "checkpoint").rename(run_dir / "checkpoint.tmp")
    messages = _resume(run_dir, reference)
    assert any("from checkpoint.tmp" in m and "missing" in m for m in messages)


def test_incomplete_tmp_is_ignored(tmp_path, reference):
    run_dir = _stopped_run(tmp_path)
    (run_dir / "checkpoint.tmp").mkdir()
    (run_dir / "checkpoint.tmp" / "model.zip").write_bytes(b"half")
    messages = _resume(run_dir, reference)
    assert any("resuming at step 384" in m for m in messages)


@pytest.mark.parametrize("broken", ["state.pkl", "model.zip"])
def test_corrupt_checkpoint_falls_back_to_the_previous(tmp_path, reference, broken):
    run_dir = _stopped_run(tmp_path)
    prev = _steps(run_dir / "checkpoint.prev")
    path = run_dir / "checkpoint" / broken
    path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])  # truncated
    messages = _resume(run_dir, reference)
    text = "\n".join(messages)
    assert "the checkpoint at step 384 is unreadable" in text
    assert f"falling back to the previous one at step {prev}" in text
    assert f"resuming at step {prev}" in text
    assert len(list(run_dir.glob("checkpoint.corrupt-*"))) == 1  # kept for inspection


def test_corrupt_and_no_previous_starts_over_saying_so(tmp_path, reference):
    run_dir = _stopped_run(tmp_path)
    shutil.rmtree(run_dir / "checkpoint.prev")
    (run_dir / "checkpoint" / "state.pkl").write_bytes(b"\x80\x05garbage")
    messages = _resume(run_dir, reference)
    assert any("no previous checkpoint: the run starts over" in m for m in messages)
