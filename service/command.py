"""What the service's long-running commands (`serve`, `serve --workers N`, `router`) share: the stop on
SIGINT or SIGTERM, and the argparse type of their counts."""

from __future__ import annotations

import argparse
import logging
import signal
import threading
from typing import Any

__all__ = ["positive_int", "stop_on_signals"]


def stop_on_signals(log: logging.Logger, doing: str) -> threading.Event:
    """An event set by SIGINT or SIGTERM, each logged on `log` as `signal N: <doing>`. The command's main
    loop waits on it, so that it shuts down from its own thread rather than inside the signal handler."""
    stop = threading.Event()

    def on_signal(signum: int, _frame: Any) -> None:
        log.info("signal %d: %s", signum, doing)
        stop.set()

    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, on_signal)
    return stop


def positive_int(text: str) -> int:
    """An argparse type: a whole number, at least 1 (`--path-work`, `--workers`; the client's
    `acphys path --budget`)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value
