"""``render_mode="human"`` over the network: the stream reaches a real rerun server (headless).

The server is rerun's own command (``rerun --bind 127.0.0.1 --port P --save FILE``, from the
``replay`` extra): it listens for gRPC as a viewer does and writes what arrives to an .rrd
file instead of showing it. The environment connects with ``MULTICRANE_RERUN_SINK=
rerun+http://127.0.0.1:P/proxy``, as a user pointing it at ``rerun --serve-web`` or a remote
viewer would; ``rerun rrd print`` then reads the file back. A few seconds; skipped without
rerun. (The in-memory sink is tested in tests/envs/test_env_options.py.)
"""

from __future__ import annotations

import re
import socket
import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

import multicrane
from multicrane.render.viewers import find_viewer

pytest.importorskip("rerun", reason="rerun not installed (pip install 'multicrane[replay]')")


def rerun_command() -> str:
    found = find_viewer()
    if found is None:
        pytest.skip("the rerun command is neither on the PATH nor beside Python")
    return found


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def logged_rows(rerun: str, path: Path, entity: str) -> int:
    """How many times ``entity`` was logged in the .rrd file (rows over its chunks)."""
    if not path.exists():
        return 0
    text = subprocess.run(
        [rerun, "rrd", "print", str(path)], capture_output=True, text=True, timeout=60
    ).stdout
    return sum(int(n) for n in re.findall(rf"with (\d+) rows \S+ \S+ - {entity} ", text))


def test_human_render_streams_every_step_to_a_rerun_server(tmp_path, monkeypatch):
    rerun, port, saved = rerun_command(), free_port(), tmp_path / "stream.rrd"
    server = subprocess.Popen(
        [rerun, "--bind", "127.0.0.1", "--port", str(port), "--save", str(saved)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        for _ in range(100):  # until it listens
            with socket.socket() as s:
                if s.connect_ex(("127.0.0.1", port)) == 0:
                    break
            time.sleep(0.1)
        monkeypatch.setenv("MULTICRANE_RERUN_SINK", f"rerun+http://127.0.0.1:{port}/proxy")
        env = multicrane.parallel_env("e2s2", n_cranes=2, render_mode="human", max_cycles=6)
        obs, _ = env.reset(seed=0)
        rng = np.random.default_rng(0)
        steps = 0
        while env.agents:
            obs, *_ = env.step(
                {a: int(rng.choice(np.flatnonzero(o["action_mask"]))) for a, o in obs.items()}
            )
            steps += 1
        env.close()
        assert steps == 6
        deadline = time.monotonic() + 30
        while logged_rows(rerun, saved, "/metrics/reward") < steps + 1:
            assert time.monotonic() < deadline, "the stream did not reach the server"
            time.sleep(0.5)
    finally:
        server.terminate()
        server.wait(timeout=30)
    # One row per reset and step, each of the three drawings.
    for entity in ("/metrics/reward", "/metrics/return", "/metrics/progress"):
        assert logged_rows(rerun, saved, entity) == steps + 1, entity
