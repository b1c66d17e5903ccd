"""Routing Ctrl-C (SIGINT) and SIGTERM to a backend's handler while a sweep runs, and back."""

from __future__ import annotations

import signal
import threading


def install(handler) -> dict:
    """Route SIGINT/SIGTERM to ``handler`` (only possible in the main thread); returns the
    previous handlers for ``restore``."""
    previous = {}
    if threading.current_thread() is not threading.main_thread():
        return previous
    for sig in (signal.SIGINT, signal.SIGTERM):
        previous[sig] = signal.signal(sig, handler)
    return previous


def restore(previous: dict) -> None:
    """Put back the handlers ``install`` replaced."""
    for sig, handler in previous.items():
        signal.signal(sig, handler)
