"""One Health, Stats and Landblocks answer for a service made of worker processes.

`acphys serve --workers N` answers `P/health`, `P/stats` and `P/landblocks`
once for the whole service: the parent asks every worker on its private
keys and merges the answers here (plain maps in, a map out; no bus).
Counters add up; latency percentiles are recomputed over the workers'
samples together (a percentile of percentiles would be wrong). The
service's loaded landblocks are those some worker serves: loaded by the
worker that owns it. Every worker holds a scene file's every landblock (its
neighbours' terrain included), so a landblock its owner unloaded is still
in the other workers' own lists, but no longer served.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

from service.capabilities import CAPABILITY_FIELDS
from service.ownership import Ownership
from service.stats import LatencyWindow

__all__ = ["WorkerView", "merge_health", "merge_stats", "merge_landblocks", "merged_window"]

#: Requests the parent answers itself: the workers' counts of these are the parent's own queries to them.
PARENT_OPS = ("health", "stats", "landblocks")


@dataclass(slots=True)
class WorkerView:
    """What the parent knows of one worker process."""

    index: int
    ownership: Ownership
    pid: int | None
    alive: bool
    instance: str | None = None
    exit_code: int | None = None
    #: times the parent started it again after it died
    restarts: int = 0

    def to_wire(self, answered: bool) -> dict[str, Any]:
        status = "ok" if self.alive and answered else ("unresponsive" if self.alive else "dead")
        out: dict[str, Any] = {"index": self.index, "instance": self.instance, "pid": self.pid, "status": status,
                               "owned": self.ownership.to_wire(), "restarts": self.restarts}
        if self.exit_code is not None:
            out["exit_code"] = self.exit_code
        return out


def _status(draining: bool, workers: Sequence[WorkerView], answered: set[int]) -> str:
    if draining:
        return "draining"
    return "ok" if all(w.alive and w.index in answered for w in workers) else "degraded"


def _sum_int(replies: Sequence[dict[str, Any]], key: str) -> int:
    return sum(int(r.get(key, 0) or 0) for r in replies)


def _served(replies: dict[int, dict[str, Any]], workers: Sequence[WorkerView], key: str) -> list[int]:
    """The landblocks of the replies' lists under `key` that the answering worker owns, sorted."""
    served: set[int] = set()
    for w in workers:
        served.update(lb for lb in (replies.get(w.index) or {}).get(key) or [] if w.ownership.owns(lb))
    return sorted(served)


def merge_health(base: dict[str, Any], replies: dict[int, dict[str, Any]], workers: Sequence[WorkerView],
                 draining: bool) -> dict[str, Any]:
    """The service's Health: `base` (the parent's instance, protocol, publish, uptime) plus the
    workers' queues and movers added up, and each worker's state."""
    got = list(replies.values())
    return {
        **base,
        "status": _status(draining, workers, set(replies)),
        "queue_depth": _sum_int(got, "queue_depth"),
        "queue_capacity": _sum_int(got, "queue_capacity"),
        "movers": _sum_int(got, "movers"),
        "workers": len(workers),
        "workers_ok": sum(1 for w in workers if w.alive and w.index in replies),
        "worker_processes": [w.to_wire(w.index in replies) for w in workers],
    }


def merged_window(samples: Sequence[Sequence[float]], counts: Sequence[int]) -> dict[str, float | int]:
    """A latency summary over every worker's samples together; `count` the sum of their counts."""
    window = LatencyWindow(size=max(1, sum(len(s) for s in samples)))
    for s in samples:
        window.extend(list(s))
    window.count = sum(counts)
    return window.summary_ms()


def merge_stats(base: dict[str, Any], parent_counts: dict[str, dict[str, int]], replies: dict[int, dict[str, Any]],
                samples: dict[int, dict[str, Any]], workers: Sequence[WorkerView], draining: bool) -> dict[str, Any]:
    """The service's Stats from the workers' Stats and latency samples; `parent_counts` has the
    requests and errors the parent answered itself."""
    got = list(replies.values())
    requests: Counter[str] = Counter()
    errors: Counter[str] = Counter(parent_counts.get("errors", {}))
    handovers: Counter[str] = Counter()
    cache: Counter[str] = Counter()
    for r in got:
        requests.update({k: v for k, v in (r.get("requests") or {}).items() if k not in PARENT_OPS})
        errors.update(r.get("errors") or {})
        handovers.update(r.get("handovers") or {})
        cache.update({k: v for k, v in (r.get("cache") or {}).items() if isinstance(v, (int, float))})
    requests.update(parent_counts.get("requests", {}))
    out = merge_health(base, replies, workers, draining)
    del out["status"]
    for name in CAPABILITY_FIELDS:  # Health's, not Stats'
        out.pop(name, None)
    out.update({
        "requests": dict(requests),
        "moves": _sum_int(got, "moves"),
        "errors": dict(errors),
        "handovers": {k: handovers.get(k, 0) for k in ("out", "in", "failed")},
        "cache": dict(cache),
        "loaded_landblocks": _served(replies, workers, "loaded_landblocks"),
    })
    for key, sample_key in (("latency_ms", "latency_s"), ("engine_ms", "engine_s")):
        out[key] = merged_window([s.get(sample_key) or [] for s in samples.values()],
                                 [int((r.get(key) or {}).get("count", 0)) for r in got])
    return out


def merge_landblocks(base: dict[str, Any], replies: dict[int, dict[str, Any]],
                     workers: Sequence[WorkerView]) -> dict[str, Any]:
    """The service's landblock list: what it owns as a whole, what its workers serve (each worker's
    loaded landblocks that it owns), and each worker's own list as it answered."""
    return {
        **base,
        "loaded": _served(replies, workers, "loaded"),
        "workers": len(workers),
        "worker_processes": [{"index": w.index, "owned": w.ownership.to_wire(),
                              "loaded": (replies.get(w.index) or {}).get("loaded", [])} for w in workers],
    }
