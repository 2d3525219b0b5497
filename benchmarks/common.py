"""Shared helpers of the benchmarks: paths, percentiles, timing, results."""

from __future__ import annotations

import gzip
import itertools
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "benchmarks" / "out"
DOC = ROOT / "docs" / "performance.md"
SHARED = Path(os.environ.get("ACPHYS_SHARED", ROOT.parent / "shared"))
ORACLE = SHARED / "oracle"

# the repo itself, not whatever copy an editable install points at
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def pct(data: Iterable[float], p: float) -> float:
    """Nearest-rank percentile (a value that was actually observed); nan when empty."""
    s = sorted(data)
    if not s:
        return math.nan
    k = max(0, min(len(s) - 1, math.ceil(p / 100.0 * len(s)) - 1))
    return s[k]


def summary(samples: list[float], scale: float = 1.0) -> dict[str, float]:
    """median, p99, max, mean (times `scale`) and count of a sample list."""
    if not samples:
        return {"n": 0, "median": math.nan, "p99": math.nan, "max": math.nan, "mean": math.nan}
    return {
        "n": len(samples),
        "median": statistics.median(samples) * scale,
        "p99": pct(samples, 99) * scale,
        "max": max(samples) * scale,
        "mean": sum(samples) / len(samples) * scale,
    }


def load_trace(name: str) -> dict[str, Any]:
    with gzip.open(ORACLE / "traces" / f"{name}.trace.json.gz", "rt", encoding="utf-8") as f:
        return json.load(f)


def machine() -> dict[str, Any]:
    info: dict[str, Any] = {
        "python": platform.python_version(),
        "implementation": platform.python_implementation(),
        "platform": platform.platform(),
        "cpus": os.cpu_count(),
    }
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    info["cpu"] = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    info["compiled_engine_modules"] = compiled_modules()
    try:
        info["loadavg_at_start"] = os.getloadavg()
    except OSError:
        pass
    return info


def compiled_modules() -> list[str]:
    """Engine modules imported from compiled extensions (.so) rather than Python source."""
    import importlib
    import pkgutil

    import engine

    out = []
    for m in pkgutil.walk_packages(engine.__path__, "engine."):
        try:
            mod = importlib.import_module(m.name)
        except Exception:  # noqa: BLE001, S112 - a module that does not import is not compiled either
            continue
        if str(getattr(mod, "__file__", "")).endswith((".so", ".pyd")):
            out.append(m.name)
    return out


class Deadline:
    """A time budget: `left()` seconds remain, `over()` once spent."""

    def __init__(self, seconds: float) -> None:
        self.end = time.monotonic() + seconds

    def left(self) -> float:
        return self.end - time.monotonic()

    def over(self) -> bool:
        return time.monotonic() >= self.end


def short_commit(root: Path = ROOT) -> str:
    """The short id of the commit checked out at `root` ("unknown" outside git)."""
    try:
        out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], check=False, cwd=root, capture_output=True,
                             text=True, timeout=10)
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    return out.stdout.strip() or "unknown"


def fmt(x: float, digits: int = 1) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "n/a"
    if isinstance(x, float) and x != 0 and (abs(x) < 10 ** -(digits + 1) or abs(x) >= 1e7):
        return f"{x:.2e}"
    return f"{x:,.{digits}f}"


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def round_trips_in_every_order(series: dict[str, Callable[[int], Any]], requests: int) -> dict[str, dict[str, float]]:
    """Each series asked `requests` times, one request of each at a time, the order of the series going
    through all their permutations in turn (`a b c`, `a c b`, `b a c`, ...); each request timed on its own
    (µs): the service benchmark's comparison of one move with its bound. A series is called with the
    request's index; a list it returns is Zenoh's replies, and must hold an answer.

    Why not in blocks, as the other series: a block of one series runs with its own processes' code warm and
    the scheduler settled on where they run, and the block before it is always the same one, so each series
    carries its own offset (seen as two series on the same key 30 µs apart in one run). Why every
    permutation and not one order rotated: in a rotation (`a b c`, `b c a`, ...) each series always follows
    the same one; over the permutations each follows each of the others equally often."""
    names = list(series)
    orders = list(itertools.permutations(names))
    samples: dict[str, list[float]] = {name: [] for name in names}
    clock = time.perf_counter
    for i in range(requests):
        for name in orders[i % len(orders)]:
            t0 = clock()
            got = series[name](i)
            samples[name].append(clock() - t0)
            if isinstance(got, list) and (not got or got[0].ok is None):
                raise RuntimeError(f"{name}: request {i} was not answered")
    return {name: summary(v, 1e6) for name, v in samples.items()}
