"""Reaching a rerun viewer: found where it is installed, or one line saying what is missing.

``spawn_viewer`` starts the native viewer: the ``rerun`` executable on ``PATH``, else the one
beside the running Python (``.venv/bin/rerun`` when a venv's programs run without activating
it); a viewer already listening on the local port is used as it is, as rerun's own ``spawn``
does. ``connect_viewer`` streams to a running viewer at a ``rerun+http://HOST:PORT/proxy``
address, after a short socket connect says something listens there. Both raise
``NoViewer`` at once, its message one line (what is missing, how to install or start a
viewer, what works headless), instead of rerun's install text or its 6 s gRPC timeout.
"""

from __future__ import annotations

import os
import shutil
import socket
import sys
from pathlib import Path
from urllib.parse import urlsplit

from multicrane.render.scene import import_rerun

LOCAL_URL = "rerun+http://127.0.0.1:9876/proxy"  # where rerun's spawn puts its viewer
CONNECT_TIMEOUT_S = 0.5
HEADLESS = "render_mode='rgb_array' and --rrd files work headless"


class NoViewer(RuntimeError):
    """No rerun viewer can be reached; the message says why and what to do, in one line."""


def find_viewer() -> str | None:
    """The rerun viewer's executable: on ``PATH``, else beside ``sys.executable``, else None."""
    beside_python = str(Path(sys.executable).parent)
    return shutil.which("rerun") or shutil.which("rerun", path=beside_python)


def has_display() -> bool:
    """Whether a native window can open: on Windows and macOS always, elsewhere when
    ``DISPLAY`` or ``WAYLAND_DISPLAY`` is set."""
    if sys.platform in ("win32", "darwin"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def listening(url: str, timeout: float = CONNECT_TIMEOUT_S) -> bool:
    """Whether something accepts connections at the host and port of ``url``."""
    parts = urlsplit(url)
    try:
        address = (parts.hostname or "127.0.0.1", parts.port or 9876)
    except ValueError as exc:  # a port that is not a number
        raise NoViewer(f"{url!r} is not a viewer address (rerun+http://HOST:PORT/proxy)") from exc
    try:
        with socket.create_connection(address, timeout=timeout):
            return True
    except OSError:
        return False


def spawn_viewer(rec, blueprint=None) -> None:
    """Stream ``rec`` to a native viewer started now (or already listening on the local
    port); ``NoViewer`` when there is no executable or no display."""
    if listening(LOCAL_URL):
        rec.connect_grpc(LOCAL_URL, default_blueprint=blueprint)
        return
    executable = find_viewer()
    if executable is None:
        raise NoViewer(
            f"no rerun viewer found (none on PATH, none beside {sys.executable}): "
            f"pip install 'multicrane[replay]' installs one; {HEADLESS}"
        )
    if not has_display():
        raise NoViewer(
            "no display for the rerun viewer (DISPLAY and WAYLAND_DISPLAY are unset): start "
            "one where there is a screen, or `rerun --serve-web` for a browser, and connect to "
            f"it (--connect URL, MULTICRANE_RERUN_SINK=URL); {HEADLESS}"
        )
    import_rerun().spawn(executable_path=executable, default_blueprint=blueprint, recording=rec)


def connect_viewer(rec, url: str | None = None, blueprint=None) -> None:
    """Stream ``rec`` to the viewer running at ``url`` (default: the local one);
    ``NoViewer`` when nothing listens there."""
    url = url or LOCAL_URL
    if not listening(url):
        raise NoViewer(
            f"no rerun viewer listens at {url}: start one there (`rerun`, or `rerun "
            f"--serve-web` without a display; pip install 'multicrane[replay]'); {HEADLESS}"
        )
    rec.connect_grpc(url, default_blueprint=blueprint)


__all__ = ["NoViewer", "connect_viewer", "find_viewer", "has_display", "spawn_viewer"]
