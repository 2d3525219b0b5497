"""Counters and latency samples the service reports on its stats key."""

from __future__ import annotations

import math
import threading
import time
from collections import Counter, deque
from typing import Any

from service.protocol import REQUEST_OPS
from service.protocol.wire import ErrorKind

__all__ = ["LatencyWindow", "ServiceStats", "REQUEST_OPS"]


class LatencyWindow:
    """The most recent `size` samples (seconds); percentiles are over those."""

    def __init__(self, size: int = 20000) -> None:
        self._samples: deque[float] = deque(maxlen=size)
        self.count = 0

    def add(self, seconds: float) -> None:
        self._samples.append(seconds)
        self.count += 1

    def extend(self, seconds: list[float]) -> None:
        self._samples.extend(seconds)
        self.count += len(seconds)

    def summary_ms(self) -> dict[str, float | int]:
        data = sorted(self._samples)
        out: dict[str, float | int] = {"count": self.count, "window": len(data)}
        if not data:
            return out | {"p50": 0.0, "p90": 0.0, "p99": 0.0, "max": 0.0, "mean": 0.0}

        def pct(p: float) -> float:
            # nearest-rank percentile: a value that was actually observed
            k = max(0, min(len(data) - 1, math.ceil(p / 100.0 * len(data)) - 1))
            return data[k] * 1000.0

        return out | {
            "p50": pct(50),
            "p90": pct(90),
            "p99": pct(99),
            "max": data[-1] * 1000.0,
            "mean": sum(data) / len(data) * 1000.0,
        }


class ServiceStats:
    """Thread-safe: bumped from zenoh callbacks and from the engine thread."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.started = time.monotonic()
        self.requests: Counter[str] = Counter()
        self.errors: Counter[str] = Counter()
        self.moves = 0
        self.handovers: Counter[str] = Counter()
        self.lb_cache: Counter[str] = Counter()
        self.latency = LatencyWindow()  # receipt to result, per move
        self.engine_time = LatencyWindow()  # inside the engine, per move

    def request(self, op: str) -> None:
        with self._lock:
            self.requests[op] += 1

    def error(self, kind: str) -> None:
        with self._lock:
            self.errors[kind] += 1

    def move_done(self, latency: float, engine: float) -> None:
        """One move resolved (a single-move request's path: no lists built for one sample)."""
        with self._lock:
            self.moves += 1
            self.latency._samples.append(latency)  # LatencyWindow.add, written out (once per move)
            self.latency.count += 1
            self.engine_time._samples.append(engine)
            self.engine_time.count += 1

    def moves_done(self, latency: list[float], engine: list[float]) -> None:
        """Moves resolved: each one's latency and time in the engine (one lock for a whole batch)."""
        with self._lock:
            self.moves += len(engine)
            self.latency.extend(latency)
            self.engine_time.extend(engine)

    def samples(self) -> dict[str, list[float]]:
        """The latency and engine-time samples kept (seconds), copied: for a parent merging workers' stats."""
        with self._lock:
            return {"latency_s": list(self.latency._samples), "engine_s": list(self.engine_time._samples)}

    def bump(self, counter: str, key: str) -> None:
        with self._lock:
            getattr(self, counter)[key] += 1

    def snapshot(self) -> dict[str, Any]:
        with self._lock:
            return {
                "uptime_s": time.monotonic() - self.started,
                "requests": {op: self.requests.get(op, 0) for op in (*REQUEST_OPS, *sorted(self.requests.keys() - set(REQUEST_OPS)))},
                "moves": self.moves,
                "errors": {k: self.errors.get(k, 0) for k in (*ErrorKind.ALL, *sorted(self.errors.keys() - set(ErrorKind.ALL)))},
                "latency_ms": self.latency.summary_ms(),
                "engine_ms": self.engine_time.summary_ms(),
                "handovers": {k: self.handovers.get(k, 0) for k in ("out", "in", "failed")},
                "landblock_cache": {k: self.lb_cache.get(k, 0) for k in ("hits", "misses")},
            }
