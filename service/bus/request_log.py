"""What the service logs about the requests it answers (logger `acphys.requests`).

- DEBUG, one line per request: its operation, key, item count, result
  (`ok` or the error kind) and the time from arrival to answer. The node
  asks `requests_logged()` once per request and, only when it is on, wraps
  the query in a `LoggedQuery`, which writes the line when the query is
  answered: with DEBUG off a request costs one boolean.
- WARNING, every error answered (a request's, or one item's of a batch or
  a push), rate-limited per error kind: at most `ERROR_LINES_PER_WINDOW`
  lines per kind in each `ERROR_WINDOW_S`-second window, then one line
  saying how many more were not logged, so that a flood of bad requests
  cannot fill a disk.

Each line also carries its fields for `--log-format json` (service/logs.py).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

import msgpack

from service.logs import FIELDS

__all__ = ["ERRORS", "ErrorLog", "LoggedQuery", "log", "log_request", "requests_logged"]

log = logging.getLogger("acphys.requests")

#: at most this many WARNING lines per error kind in each window
ERROR_LINES_PER_WINDOW = 10
ERROR_WINDOW_S = 1.0


#: `requests_logged()`: whether the per-request DEBUG lines are on (the logger's own cached level check,
#: called without a function of ours around it: it is asked once per request)
requests_logged: Callable[[], bool] = partial(log.isEnabledFor, logging.DEBUG)


@dataclass(slots=True)
class _Window:
    start: float
    logged: int = 0
    suppressed: int = 0


class ErrorLog:
    """The WARNING line of each error answered, at most `lines` per error kind per `window` seconds; the
    lines held back are counted and summed up in one line when the window is over (at the next error of
    that kind, or at `flush`, which the serving loop calls)."""

    def __init__(self, logger: logging.Logger = log, lines: int = ERROR_LINES_PER_WINDOW,
                 window: float = ERROR_WINDOW_S, clock: Callable[[], float] = time.monotonic) -> None:
        self.logger, self.lines, self.window, self.clock = logger, lines, window, clock
        self._windows: dict[str, _Window] = {}
        self._lock = threading.Lock()

    def error(self, kind: str, op: str, key: str, message: str, **fields: Any) -> None:
        """Log an error answered on `key` (a request of `op`), unless this kind's window is full."""
        if not self.logger.isEnabledFor(logging.WARNING):
            return
        with self._lock:
            now = self.clock()
            w = self._windows.get(kind)
            summary = None
            if w is None or now - w.start >= self.window:
                if w is not None and w.suppressed:
                    summary = (kind, w.suppressed, now - w.start)
                w = self._windows[kind] = _Window(now)
            show = w.logged < self.lines
            if show:
                w.logged += 1
            else:
                w.suppressed += 1
        if summary is not None:
            self._summary(*summary)
        if show:
            self.logger.warning("%s answered %s on %s: %s", op, kind, key, message,
                                extra={FIELDS: {"event": "error", "op": op, "key": key, "kind": kind,
                                                "error": message, **fields}})

    def flush(self, everything: bool = False) -> None:
        """Say how many lines were held back in every window that is over (`everything`: in every window,
        as at shutdown)."""
        now = self.clock()
        with self._lock:
            done = [(k, w.suppressed, now - w.start) for k, w in self._windows.items()
                    if w.suppressed and (everything or now - w.start >= self.window)]
            for k, _n, _s in done:
                del self._windows[k]
        for summary in done:
            self._summary(*summary)

    def _summary(self, kind: str, suppressed: int, seconds: float) -> None:
        self.logger.warning("%d more %s error(s) answered in the last %.1f s, not logged one by one", suppressed,
                            kind, seconds, extra={FIELDS: {"event": "errors_not_logged", "kind": kind,
                                                           "count": suppressed, "seconds": round(seconds, 3)}})


#: the process's one error log (every node and tenant of a process shares its limit)
ERRORS = ErrorLog()


class LoggedQuery:
    """A zenoh.Query stand-in that writes the request's DEBUG line when it is answered (dropped)."""

    __slots__ = ("query", "key_expr", "op", "received", "items", "result")

    def __init__(self, query: Any, op: str, received: float) -> None:
        self.query = query
        self.key_expr = query.key_expr
        self.op = op
        self.received = received
        self.items: int | None = None
        self.result = "unanswered"

    @property
    def payload(self) -> Any:
        return self.query.payload

    def reply(self, key: Any, payload: Any) -> None:
        self.result = "ok"
        self.query.reply(key, payload)

    def reply_err(self, payload: bytes) -> None:
        try:
            self.result = str(msgpack.unpackb(payload, raw=False)["error"]["kind"])
        except Exception:  # not one of ours: still answered, as an error
            self.result = "error"
        self.query.reply_err(payload)

    def drop(self) -> None:
        try:
            self.query.drop()
        finally:
            log_request(self.op, str(self.key_expr), self.items, self.result, self.received)


def log_request(op: str, key: str, items: int | None, result: str, received: float) -> None:
    """The DEBUG line of one request (call only when `requests_logged()`)."""
    ms = (time.monotonic() - received) * 1000.0
    shown = "" if items is None else f"{items} item(s), "
    log.debug("%s %s: %s%s, %.3f ms", op, key, shown, result, ms,
              extra={FIELDS: {"event": "request", "op": op, "key": key, "items": items, "result": result,
                              "ms": round(ms, 3)}})
