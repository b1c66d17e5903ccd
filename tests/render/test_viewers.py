"""Reaching a rerun viewer (``multicrane.render.viewers``): found on PATH or beside Python, and
one line, never a traceback or a timeout, when there is none, no display or no listener.

The lookup's inputs are monkeypatched: ``PATH``, ``sys.executable``'s folder, ``DISPLAY`` and
the local viewer's address (a free port, so that a viewer running on this machine does not
count). ``render_mode="human"`` then warns once and goes on, so PettingZoo's ``render_test``
passes for every render mode without any project-specific variable.
"""

from __future__ import annotations

import functools
import socket
import sys
import time
import warnings

import pytest
from pettingzoo.test import render_test

import multicrane
from multicrane.cli import main
from multicrane.render import viewers
from multicrane.render.viewers import NoViewer, connect_viewer, find_viewer, spawn_viewer


def _free_url() -> str:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return f"rerun+http://127.0.0.1:{s.getsockname()[1]}/proxy"


def _executable(folder) -> str:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "rerun"
    path.write_text("#!/bin/sh\nexit 0\n")
    path.chmod(0o755)
    return str(path)


@pytest.fixture
def no_viewer(tmp_path, monkeypatch):
    """No rerun on PATH, none beside Python, a display, nothing on the local port."""
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    monkeypatch.setattr(sys, "executable", str(tmp_path / "venv" / "bin" / "python"))
    monkeypatch.setattr(sys, "platform", "linux")
    monkeypatch.setenv("DISPLAY", ":0")
    monkeypatch.setattr(viewers, "LOCAL_URL", _free_url())
    monkeypatch.delenv("MULTICRANE_RERUN_SINK", raising=False)
    return tmp_path


class _Stream:
    """A stand-in for rerun's RecordingStream and module: records what was called."""

    def __init__(self):
        self.calls = []

    def connect_grpc(self, url, default_blueprint=None):
        self.calls.append(("connect_grpc", url))

    def spawn(self, **kwargs):
        self.calls.append(("spawn", kwargs["executable_path"], kwargs["recording"]))


def _one_line(exc: pytest.ExceptionInfo) -> str:
    text = str(exc.value)
    assert "\n" not in text
    return text


# -- the lookup ---------------------------------------------------------------------------


def test_the_viewer_on_path_comes_first(no_viewer, monkeypatch):
    on_path = _executable(no_viewer / "bin")
    _executable(no_viewer / "venv" / "bin")
    monkeypatch.setenv("PATH", str(no_viewer / "bin"))
    assert find_viewer() == on_path


def test_the_viewer_beside_python_when_not_on_path(no_viewer):
    assert find_viewer() is None
    beside = _executable(no_viewer / "venv" / "bin")
    assert find_viewer() == beside


def test_spawn_starts_the_viewer_beside_python(no_viewer, monkeypatch):
    beside = _executable(no_viewer / "venv" / "bin")
    rr, rec = _Stream(), object()
    monkeypatch.setattr(viewers, "import_rerun", lambda: rr)
    spawn_viewer(rec)
    assert rr.calls == [("spawn", beside, rec)]


def test_spawn_uses_a_viewer_already_listening_on_the_local_port(no_viewer, monkeypatch):
    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen()
        url = f"rerun+http://127.0.0.1:{server.getsockname()[1]}/proxy"
        monkeypatch.setattr(viewers, "LOCAL_URL", url)
        rec = _Stream()
        spawn_viewer(rec)
    assert rec.calls == [("connect_grpc", url)]


# -- one line when there is none --------------------------------------------------------


def test_no_viewer_anywhere_says_how_to_install_one(no_viewer):
    with pytest.raises(NoViewer) as exc:
        spawn_viewer(_Stream())
    text = _one_line(exc)
    assert "no rerun viewer found" in text and "PATH" in text
    assert "pip install 'multicrane[replay]'" in text
    assert "rgb_array" in text and "--rrd" in text


def test_no_display_says_how_to_start_a_viewer_elsewhere(no_viewer, monkeypatch):
    _executable(no_viewer / "venv" / "bin")
    monkeypatch.delenv("DISPLAY")
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(NoViewer) as exc:
        spawn_viewer(_Stream())
    text = _one_line(exc)
    assert "no display" in text and "rerun --serve-web" in text and "rgb_array" in text


def test_an_address_nobody_listens_on_fails_at_once(no_viewer):
    url = _free_url()
    start = time.monotonic()
    with pytest.raises(NoViewer) as exc:
        connect_viewer(_Stream(), url)
    assert time.monotonic() - start < 2  # not rerun's 6 s gRPC timeout
    text = _one_line(exc)
    assert f"no rerun viewer listens at {url}" in text and "rerun --serve-web" in text
    with pytest.raises(NoViewer, match="not a viewer address"):
        connect_viewer(_Stream(), "rerun+http://127.0.0.1:port/proxy")


def test_an_address_with_a_listener_is_connected(no_viewer):
    with socket.socket() as server:
        server.bind(("127.0.0.1", 0))
        server.listen()
        url = f"rerun+http://127.0.0.1:{server.getsockname()[1]}/proxy"
        rec = _Stream()
        connect_viewer(rec, url)
    assert rec.calls == [("connect_grpc", url)]


# -- render_mode="human" goes on without a viewer -----------------------------------------


def _headless(case: str, no_viewer, monkeypatch) -> None:
    if case == "no display":  # the viewer is installed, the machine has no screen
        _executable(no_viewer / "venv" / "bin")
        monkeypatch.delenv("DISPLAY")
    elif case == "nothing listens":
        monkeypatch.setenv("MULTICRANE_RERUN_SINK", _free_url())


@pytest.mark.parametrize("case", ["no viewer", "no display", "nothing listens"])
def test_human_mode_warns_once_and_runs_on(case, no_viewer, monkeypatch):
    pytest.importorskip("rerun")
    _headless(case, no_viewer, monkeypatch)
    env = multicrane.parallel_env("e2s2", render_mode="human")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env.reset(seed=0)
        for _ in range(3):
            env.step({a: env.wait_action for a in env.agents})
            assert env.render() is None
        env.reset(seed=1)
        env.close()
    shown = [w for w in caught if "render_mode='human' shows nothing" in str(w.message)]
    assert len(shown) == 1, [str(w.message) for w in caught]
    assert "\n" not in str(shown[0].message)


@pytest.mark.parametrize("case", ["no viewer", "no display"])
def test_pettingzoo_render_test_passes_for_every_render_mode(case, no_viewer, monkeypatch):
    pytest.importorskip("rerun")
    _headless(case, no_viewer, monkeypatch)
    assert multicrane.MultiCraneEnv.metadata["render_modes"] == ["ansi", "rgb_array", "human"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        render_test(functools.partial(multicrane.env, "e2s2"))
        render_test(functools.partial(multicrane.env, "hall-4c", decisions="task"))


# -- the command line: one line, status 2 -------------------------------------------------


def _error_line(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    return lines[0]


def test_replay_spawn_without_a_viewer_says_so_in_one_line(no_viewer, capsys, tmp_path):
    pytest.importorskip("rerun")
    record = tmp_path / "ep.json.gz"
    assert main(["replay", "record", "--scenario", "e2s2", "--max-steps", "5",
                 "--record", str(record)]) == 0  # fmt: skip
    capsys.readouterr()
    assert main(["replay", "replay", str(record), "--spawn"]) == 2
    assert _error_line(capsys).startswith("error: no rerun viewer found")
    assert main(["replay", "live", "--scenario", "e2s2", "--max-steps", "5"]) == 2
    assert "pip install 'multicrane[replay]'" in _error_line(capsys)


def test_replay_connect_to_an_address_nobody_listens_on(no_viewer, capsys):
    pytest.importorskip("rerun")
    url = _free_url()
    start = time.monotonic()
    assert main(["replay", "live", "--scenario", "e2s2", "--max-steps", "5", "--connect", url]) == 2
    assert time.monotonic() - start < 5
    assert _error_line(capsys).startswith(f"error: no rerun viewer listens at {url}")
