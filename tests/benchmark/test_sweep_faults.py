"""Sweeps under faults (issue 20): run locks naming their owner, dead owners taken over, and
workers that end when their driver is killed with SIGKILL.

Before the fix, killing the sweep driver with SIGKILL left its workers training, and a second
sweep then trained the same run twice at once, both writing one directory.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

from multicrane.benchmark.jobs import Job, execute_run
from multicrane.training.run_lock import LOCK, RunLock, RunLockedError, owner

ROOT = Path(__file__).resolve().parents[2]

HOLDER = """
import sys, time
from multicrane.training.run_lock import RunLock
with RunLock(sys.argv[1], log=print):
    print("locked", flush=True)
    time.sleep(120)
"""


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    # A zombie (dead, not yet reaped by its new parent) counts as ended.
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().split(")")[-1].split()[0] != "Z"
    except OSError:
        return True


def _python(script: str, *args: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1"}
    return subprocess.Popen(
        [sys.executable, "-c", script, *args], env=env, stdout=subprocess.PIPE, text=True
    )


def _wait(predicate, seconds: float) -> bool:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.05)
    return predicate()


def test_lock_names_its_owner_and_a_dead_owner_is_taken_over(tmp_path):
    holder = _python(HOLDER, str(tmp_path))
    try:
        assert holder.stdout.readline().strip() == "locked"
        info = owner(tmp_path)
        assert info is not None and info["pid"] == holder.pid and info["host"] and info["started"]
        with pytest.raises(RunLockedError, match=f"in use by process {holder.pid} on "):
            RunLock(tmp_path).acquire()
        holder.send_signal(signal.SIGKILL)  # no handler runs: the file stays behind
        holder.wait(10)
        assert (tmp_path / LOCK).exists()
        messages: list[str] = []
        with RunLock(tmp_path, log=messages.append):
            assert owner(tmp_path)["pid"] == os.getpid()
        assert len(messages) == 1 and f"process {holder.pid}" in messages[0]
        assert "which has ended" in messages[0]
        assert not (tmp_path / LOCK).exists() and owner(tmp_path) is None
    finally:
        holder.kill()
        holder.wait()


def test_a_run_held_by_a_live_process_is_not_trained_twice(tmp_path):
    run_dir = tmp_path / "run"
    holder = _python(HOLDER, str(run_dir))
    try:
        assert holder.stdout.readline().strip() == "locked"
        train = dict(scenario="E1S1", algo="ppo", total_steps=64, eval_episodes=1)
        outcome = execute_run(Job("r", str(run_dir), train))
        assert outcome.status == "failed"
        assert f"in use by process {holder.pid}" in outcome.error
        assert sorted(p.name for p in run_dir.iterdir()) == [LOCK]  # nothing written
    finally:
        holder.kill()
        holder.wait()


RUNNER = """
import os, time
from multicrane.benchmark.jobs import Outcome

def slow(task):
    with open(task.run_dir, "w") as f:
        f.write(str(os.getpid()))
    time.sleep(120)
    return Outcome(task.name, "done")
"""

DRIVER = """
import sys
sys.path.insert(0, sys.argv[1])
from fake_runner import slow
from multicrane.benchmark.local import LocalBackend
from multicrane.benchmark.jobs import Job

backend = LocalBackend(workers=1, runner=slow, orphan_grace=1.0)
backend.run([Job("r", sys.argv[2], {})], print)
"""


def test_workers_end_when_the_driver_is_killed(tmp_path):
    (tmp_path / "fake_runner.py").write_text(textwrap.dedent(RUNNER))
    pid_file = tmp_path / "worker.pid"
    driver = _python(DRIVER, str(tmp_path), str(pid_file))
    try:
        assert _wait(lambda: pid_file.exists() and pid_file.read_text(), 60), "no worker"
        worker = int(pid_file.read_text())
        assert _alive(worker)
        driver.send_signal(signal.SIGKILL)
        driver.wait(10)
        # Noticed within a poll (0.5 s), SIGTERM ignored by this runner, ended after 1 s.
        assert _wait(lambda: not _alive(worker), 15), f"worker {worker} outlived its driver"
    finally:
        driver.kill()
        driver.wait()
        if pid_file.exists() and pid_file.read_text():
            with contextlib.suppress(ProcessLookupError):
                os.kill(int(pid_file.read_text()), signal.SIGKILL)


def test_lock_file_is_json_naming_the_owner(tmp_path):
    with RunLock(tmp_path):
        data = json.loads((tmp_path / LOCK).read_text())
        assert data["pid"] == os.getpid() and set(data) == {"pid", "host", "started"}


def test_train_command_on_a_locked_run_is_one_error_line(tmp_path, capsys):
    pytest.importorskip("stable_baselines3")
    from multicrane.cli import main

    run_dir = tmp_path / "run"
    holder = _python(HOLDER, str(run_dir))
    try:
        assert holder.stdout.readline().strip() == "locked"
        argv = ["train", "--paper", "E1S1", "--algo", "ppo", "--steps", "64", "--out", str(run_dir)]
        assert main(argv) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"in use by process {holder.pid}" in err[0], err
    finally:
        holder.kill()
        holder.wait()
