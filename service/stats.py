"""Counters and latency samples the service reports on its stats key."""

from __future__ import annotations

import math
import struct
import threading
import time
from collections import deque
from typing import Any

from service.protocol import REQUEST_OPS
from service.protocol.wire import ErrorKind

__all__ = ["LatencyWindow", "ServiceStats", "REQUEST_OPS"]


#: At most this many single samples share a chunk (so that a window of single moves drops old ones
#: a chunk at a time without keeping more than this many beyond its size).
_SINGLES_PER_CHUNK = 1024


class LatencyWindow:
    """The most recent `size` samples (seconds); percentiles are over those.

    Samples are kept in chunks, each its values and a shift to add to every value: a column
    batch hands over the engine's finishing times of its moves as little-endian float64 bytes (its batch
    rows', engine.world.batch.BatchRows) with the shift that makes them latencies, so that recording a
    batch costs the same whatever its length, no Python float is kept per move, and the values are
    worked out only when a summary is asked for. Single samples gather in a list chunk of their own
    (shift 0). The oldest chunks are dropped once the newer ones hold `size` samples."""

    def __init__(self, size: int = 20000) -> None:
        self.size = size
        self._chunks: deque[tuple[float, list[float] | bytes]] = deque()
        self._kept = 0  # samples in _chunks
        self._singles: list[float] | None = None  # the last chunk, while single samples go into it
        self.count = 0

    def add(self, seconds: float) -> None:
        singles = self._singles
        if singles is None or len(singles) >= _SINGLES_PER_CHUNK:
            singles = self._singles = []
            self._chunks.append((0.0, singles))
        singles.append(seconds)
        self._kept += 1
        self.count += 1
        if self._kept - _count(self._chunks[0][1]) >= self.size:
            self._drop_oldest()

    def extend(self, seconds: list[float]) -> None:
        self._append_chunk(0.0, list(seconds))

    def extend_shifted(self, shift: float, values: bytes) -> None:
        """Samples `shift + v` for each little-endian float64 v of `values`."""
        self._append_chunk(shift, values)

    def _append_chunk(self, shift: float, values: list[float] | bytes) -> None:
        chunks = self._chunks
        chunks.append((shift, values))
        self._singles = None
        n = _count(values)
        self._kept += n
        self.count += n
        if self._kept - _count(chunks[0][1]) >= self.size:
            self._drop_oldest()

    def _drop_oldest(self) -> None:
        """Drop the oldest chunks while the others still hold `size` samples."""
        chunks = self._chunks
        while len(chunks) > 1 and self._kept - _count(chunks[0][1]) >= self.size:
            self._kept -= _count(chunks.popleft()[1])

    def samples(self) -> list[float]:
        """The latest `size` samples, oldest first."""
        out: list[float] = []
        for shift, values in self._chunks:
            if isinstance(values, bytes):
                read = struct.unpack(f"<{len(values) // 8}d", values)
                out.extend(read if shift == 0.0 else [shift + v for v in read])
            else:
                out.extend(values)  # a list chunk's shift is 0
        return out[-self.size:] if len(out) > self.size else out

    def summary_ms(self) -> dict[str, float | int]:
        data = sorted(self.samples())
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


def _count(values: list[float] | bytes) -> int:
    """How many samples a chunk's values hold: a list's floats, or the bytes' float64s."""
    return len(values) // 8 if isinstance(values, bytes) else len(values)


class ServiceStats:
    """Thread-safe: bumped from zenoh callbacks and from the engine thread.

    The counters are plain dicts (a key counts from 0): the compiled install compiles this module
    (setup.py), and mypyc reads and writes a dict natively, a Counter only through Python's protocols."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.started = time.monotonic()
        self.requests: dict[str, int] = {}
        self.errors: dict[str, int] = {}
        self.moves = 0
        self.handovers: dict[str, int] = {}
        self.lb_cache: dict[str, int] = {}
        self.latency = LatencyWindow()  # receipt to result, per move
        self.engine_time = LatencyWindow()  # inside the engine, per move

    def request(self, op: str) -> None:
        with self._lock:
            counts = self.requests
            counts[op] = counts.get(op, 0) + 1

    def error(self, kind: str) -> None:
        with self._lock:
            counts = self.errors
            counts[kind] = counts.get(kind, 0) + 1

    def move_done(self, latency: float, engine: float) -> None:
        """One move resolved (a single-move request's path: no lists built for one sample)."""
        with self._lock:
            self.moves += 1
            self.latency.add(latency)
            self.engine_time.add(engine)

    def moves_done(self, latency: list[float], engine: list[float]) -> None:
        """Moves resolved: each one's latency and time in the engine (one lock for a whole batch)."""
        with self._lock:
            self.moves += len(engine)
            self.latency.extend(latency)
            self.engine_time.extend(engine)

    def batch_done(self, shift: float, finished_at: bytes, engine: bytes) -> None:
        """A column batch's moves resolved: each one's latency is `shift` plus its finishing time, and its
        time in the engine, as little-endian float64s (the engine's batch rows', kept as they are)."""
        with self._lock:
            self.moves += len(engine) // 8
            self.latency.extend_shifted(shift, finished_at)
            self.engine_time.extend_shifted(0.0, engine)

    def samples(self) -> dict[str, list[float]]:
        """The latency and engine-time samples kept (seconds), copied: for a parent merging workers' stats."""
        with self._lock:
            return {"latency_s": self.latency.samples(), "engine_s": self.engine_time.samples()}

    def bump(self, counter: str, key: str) -> None:
        """Count one `key` in the counter named `counter` ("handovers" or "lb_cache")."""
        with self._lock:
            counts: dict[str, int] = getattr(self, counter)
            counts[key] = counts.get(key, 0) + 1

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
