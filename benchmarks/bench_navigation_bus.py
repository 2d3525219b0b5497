"""Navigation over the bus: the path queries of the navigation benchmark asked of a service
(`python -m service` on the same scene file) through the client library, beside the library's own
figures for the same pairs in the same run.

Three forms per set of pairs: `Client.path` one request each (p50, p90), `Client.paths` (the batch form:
one request per start landblock, at most 64 paths each) and the column form (docs/protocol.md, "Path
columns": a raw request through `Client._lb_request`, one per start landblock), both per path. The
service builds its graphs lazily, as a search reaches them; asking every pair once first (unmeasured)
walks every edge those searches expand, so the timed queries run on a built graph as the library's do.
Bounded by counts; loopback only."""

from __future__ import annotations

import math
import statistics
import sys
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from .common import log, pct, summary

#: the column-form request columns of a path (docs/protocol.md, "Path columns")
_COLUMN_OP = "path"
#: rounds of each batch form (their median per path is reported)
_BATCH_ROUNDS = 3
#: seconds a request may take: a warm-up path builds graphs (seconds each in pure Python)
_TIMEOUT = 300.0

Pair = tuple[Any, Any]


def _loadavg() -> list[float]:
    try:
        with open("/proc/loadavg", encoding="ascii") as f:
            return [float(x) for x in f.read().split()[:3]]
    except OSError:  # not Linux: the report says so by leaving it empty
        return []


def _by_start_landblock(pairs: Sequence[Pair]) -> list[list[Pair]]:
    """The pairs split as the batch forms send them: by start landblock, at most 64 a request."""
    from service.protocol.queries import MAX_PATH_BATCH

    groups: dict[int, list[Pair]] = {}
    for a, b in pairs:
        groups.setdefault(a.landblock, []).append((a, b))
    return [g[k:k + MAX_PATH_BATCH] for g in groups.values() for k in range(0, len(g), MAX_PATH_BATCH)]


def _column_body(walker: Any, pairs: Sequence[Pair]) -> dict[str, Any]:
    """One column request of these pairs (all starting in one landblock)."""
    import numpy as np

    from service.protocol.codec import encode_mover_spec
    from service.protocol.columns import pack_columns
    from service.protocol import QUERY_COLUMNS

    arrays = {
        "from_cell": np.array([a.cell_id for a, _ in pairs], dtype=np.uint32),
        "from_origin": np.array([[a.frame.origin.x, a.frame.origin.y, a.frame.origin.z] for a, _ in pairs]),
        "to_cell": np.array([b.cell_id for _, b in pairs], dtype=np.uint32),
        "to_origin": np.array([[b.frame.origin.x, b.frame.origin.y, b.frame.origin.z] for _, b in pairs]),
    }
    return {"v": 1, "mover": encode_mover_spec(walker),
            "columns": pack_columns(QUERY_COLUMNS[_COLUMN_OP].request, arrays)}


def _column_found(reply: dict[str, Any], n: int) -> int:
    """How many of a column reply's `n` items were found (flags bit `found`)."""
    from service.protocol.columns import unpack_column
    from service.protocol import QUERY_COLUMNS

    spec = QUERY_COLUMNS[_COLUMN_OP]
    flags = unpack_column(next(c for c in spec.reply if c.name == "flags"), reply["columns"]["flags"], n)
    return int(((flags & spec.bit("found")) != 0).sum())


def _one_set(client: Any, walker: Any, pairs: Sequence[Pair], library: dict[str, Any]) -> dict[str, Any]:
    """Warm, then time one set of pairs in the three forms; the library's figures for them beside."""
    clock = time.perf_counter
    warm_found = sum(client.path(walker, a, b, timeout=_TIMEOUT).found for a, b in pairs)
    times, found = [], 0
    for a, b in pairs:
        t0 = clock()
        r = client.path(walker, a, b, timeout=_TIMEOUT)
        times.append(clock() - t0)
        found += r.found
    groups = _by_start_landblock(pairs)
    n = max(1, len(pairs))
    batched, batch_found = [], 0
    for _ in range(_BATCH_ROUNDS):
        t0 = clock()
        answers = [r for g in groups for r in client.paths(walker, g, timeout=_TIMEOUT)]
        batched.append((clock() - t0) / n)
        batch_found = sum(bool(getattr(r, "found", False)) for r in answers)
    bodies = [(g[0][0].landblock, len(g), _column_body(walker, g)) for g in groups]
    columns, column_found = [], 0
    for _ in range(_BATCH_ROUNDS):
        t0 = clock()
        replies = [(client._lb_request(lb, _COLUMN_OP, body, timeout=_TIMEOUT), m) for lb, m, body in bodies]
        columns.append((clock() - t0) / n)
        column_found = sum(_column_found(reply, m) for reply, m in replies)
    single = summary(times, 1e3)
    row: dict[str, Any] = {
        "pairs": len(pairs), "requests": len(groups),
        "median": single["median"], "p90": pct(times, 90) * 1e3, "p99": single["p99"], "mean": single["mean"],
        "batched_mean_ms": statistics.median(batched) * 1e3, "columns_mean_ms": statistics.median(columns) * 1e3,
        "found": found, "warm_found": warm_found, "batch_found": batch_found, "column_found": column_found,
        "library_median": library["median"], "library_p90": library.get("p90", math.nan),
        "library_batched_mean_ms": library["batched_mean_ms"], "library_found": library["found"],
    }
    # what the bus adds: the median of each pair's bus time less its library time (pairs of one set differ
    # a hundredfold in cost, so a difference of the two medians is mostly which pairs sit at them)
    lib_times = library.get("times_ms")
    row["added_ms"] = (statistics.median(t * 1e3 - u for t, u in zip(times, lib_times, strict=True))
                       if lib_times and len(lib_times) == len(times) else row["median"] - row["library_median"])
    row["medians_added_ms"] = row["median"] - row["library_median"]
    row["batched_added_ms"] = row["batched_mean_ms"] - row["library_batched_mean_ms"]
    return row


def _health_ms(client: Any, rounds: int) -> float:
    """The bus's floor per request here: a health request, which the service answers with no engine work
    (median, ms)."""
    times = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        client.health()
        times.append(time.perf_counter() - t0)
    return statistics.median(times) * 1e3


def bus_paths(scene: Path, walker: Any, sets: Mapping[str, Sequence[Pair]],
              library: Mapping[str, dict[str, Any]]) -> dict[str, Any]:
    """Start a service on `scene`, ask it each set's pairs as `_one_set` does, stop it. `library`: the
    library's figures of the same sets by name (bench_navigation._time_paths)."""
    import zenoh  # noqa: F401 - fail early, with a clear message, when zenoh is missing

    from clients import Client

    from .service_harness import Child, free_port

    endpoint = f"tcp/127.0.0.1:{free_port()}"
    load_before = _loadavg()
    service = Child([sys.executable, "-m", "service", "--scene", str(scene), "--listen", endpoint,
                     "--log-level", "WARNING"], "acphys service ready")
    rows: dict[str, Any] = {}
    try:
        with Client([endpoint], timeout=_TIMEOUT) as client:
            health_ms = _health_ms(client, 50)
            for name, pairs in sets.items():
                rows[name] = _one_set(client, walker, pairs, library[name])
                v = rows[name]
                log(f"  over the bus, {name}: p50 {v['median']:.2f} ms (library {v['library_median']:.2f}), "
                    f"p90 {v['p90']:.2f}, batched {v['batched_mean_ms']:.2f} / path, columns "
                    f"{v['columns_mean_ms']:.2f} / path, {v['found']}/{v['pairs']} found")
    finally:
        service.stop()
    return {"sets": rows, "health_ms": health_ms, "scene": scene.name, "loadavg_before": load_before,
            "loadavg_after": _loadavg(),
            "endpoint": "tcp/127.0.0.1 (loopback), peer mode, one service process (python -m service)"}


def bus_section(bus: dict[str, Any] | None) -> list[str]:
    """docs/performance.md's lines for the bus figures (none when the run has none)."""
    if not bus:
        return ["Over the bus: not measured in this run.", ""]
    if "failed" in bus:
        return [f"Over the bus: not measured: {bus['failed']}", ""]
    before, after = bus.get("loadavg_before") or [math.nan], bus.get("loadavg_after") or [math.nan]
    out = [f"The same pairs over the bus, in the same run: a service (`python -m service --scene {bus['scene']}`, "
           "one process) on loopback asked by the client library. `Client.path` one request a path (p50, p90); "
           "`Client.paths`, the batch form, one request per start landblock (at most 64 paths; 'requests' "
           "counts them) and the column form (docs/protocol.md, \"Path columns\", one raw request per start "
           "landblock), per path, the median of three rounds. Every pair was asked once first, unmeasured: "
           "the service builds its graph as searches reach it, so the timed queries run on a built graph as "
           "the library's above do. 'Bus adds' is the median over the pairs of each one's bus time less its "
           "library time (the pairs of a set differ a hundredfold in cost; the two p50s are beside it): "
           "msgpack both ways, Zenoh on loopback, the service's queue to its engine thread. A health request "
           f"(no engine work) took {bus['health_ms']:.2f} ms at the median. Load average "
           f"{before[0]:.1f} before and {after[0]:.1f} after, on two cores shared with other work.", "",
           "| paths | library p50 ms | bus p50 ms | bus p90 ms | bus adds, ms | library batched, ms/path | "
           "bus batched, ms/path | bus columns, ms/path | requests | found (library / bus) |",
           "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for k, v in bus["sets"].items():
        out.append(f"| {k} | {v['library_median']:.2f} | {v['median']:.2f} | {v['p90']:.2f} | {v['added_ms']:+.2f} | "
                   f"{v['library_batched_mean_ms']:.2f} | {v['batched_mean_ms']:.2f} | {v['columns_mean_ms']:.2f} | "
                   f"{v['requests']} | {v['library_found']} / {v['found']} |")
    return out + [""]


def bus_finding(bus: dict[str, Any] | None, cpus: int = 2) -> list[str]:
    """The finding on the bus's cost per path, from this run's figures (`cpus`: the machine's, to say
    when its load was above them)."""
    if not bus or "failed" in bus or not bus.get("sets"):
        return []
    sets = bus["sets"]
    adds = [v["added_ms"] for v in sets.values()]
    q = sets.get("150 m") or next(iter(sets.values()))
    name = "150 m" if "150 m" in sets else next(iter(sets))
    agree = all(v["found"] == v["library_found"] == v["batch_found"] == v["column_found"] for v in sets.values())
    return ["", f"**Over the bus.** A {name} path asked with `Client.path` took {q['median']:.2f} ms at the median "
            f"({q['p90']:.2f} ms p90) against the library's {q['library_median']:.2f} ms for the same pairs; pair by "
            f"pair the bus adds {q['added_ms']:.2f} ms a path at the median (from {min(adds):.2f} to {max(adds):.2f} ms over the sets; a health "
            f"request, which does no engine work, takes {bus['health_ms']:.2f} ms). The batch form costs "
            f"{q['batched_mean_ms']:.2f} ms a path ({q['batched_added_ms']:+.2f} ms on `World.paths`) and the column "
            f"form {q['columns_mean_ms']:.2f} ms: a batch shares one round trip among its paths, so what the bus "
            "adds to a batched path is its share of that trip and of the encoding of its waypoints. "
            + ("Every form found the same paths as the library." if agree else
               "The forms did not all find as many paths as the library: see the table's last column.")
            + (f" The machine was busy through this part (load average {bus['loadavg_before'][0]:.1f} on {cpus} "
               "cores, other work running): a single path's time swings by milliseconds between repeats, so what the "
               "bus adds is read from the per-pair median, and a figure below zero is that noise."
               if bus.get("loadavg_before") and bus["loadavg_before"][0] > cpus else "")]
