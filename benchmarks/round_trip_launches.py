"""One move's round trip against its bound, measured in several fresh launches of every process.

The service benchmark (bench_service.latency) measures the round trip once, with its processes started once.
On this 2-core machine a launch's figure depends on the launch: where the scheduler puts the service, the
bound's process and the asking process, and how their memory falls, decide several µs that stay for the whole
launch. Seven launches of one tree gave `Client.move` 45 to 60 µs over the bound (median 50), while the
median of one launch's requests moves by about a microsecond. One launch's figure is one draw, so the
target is read here from several launches: 21, with their quartiles, as the launches of one tree spread over
20 µs and the median of seven moved by as much as the target's margin between sets. A launch takes 5 to 30 s,
by the machine.

A set of launches is itself one draw of the machine's state. On the project's 2-core VM, sets of 14 to 21
launches of one tree, run within the same hour, had medians from 37 to 46 µs, and identical copies of one
tree, launched in turn, differed by 2 to 4 µs (one copy lower in 32 of 42 pairs). So the launches are also
run with every process pinned to one core (`ONE_CORE_LAUNCHES`, the launch's affinity set before anything
starts, which its children inherit): a request then wakes its server on the core it is already on, and
their bound is 50 to 70 µs faster. A scratch set of 20 such launches spread over 32 to 38 µs; the 11 of the
first benchmark run with them over 34 to 50. The target's verdict is read from the unpinned launches, the
machine as it is; the one-core figure stands beside it.

The figure also depends on what runs between two requests of a series, not only on the code: asking a
fourth series beside the three (the raw request again, on a declared key) lowered `Client.move`'s figure by
about 8 µs in the same launches, and blocks of 100 (bench_service.latency) raise it by about 20. The three
series in every order are the design whose rule is plain (each follows each of the others equally often).

Each launch is a child process (`python3 -m benchmarks.round_trip_launches launch`) that starts its own
`python -m service` and bound (bench_service.engine_echo_main) on free loopback ports, asks the bound, the raw
move request and `Client.move` one request at a time in every order (common.round_trips_in_every_order),
stops the service, then measures its floor (below). The figure is each launch's `move - bound`, and its median
over the launches; the raw request splits it into the service's and the client library's share.

What bounds that figure from below is measured in the same launch, in a second phase of the same design:
the service stopped, the bound and the protocol's floor asked one request at a time in every order, three
series as in the first phase. The floor is one move as docs/protocol.md alone makes any service and client
do it, in Python, with the libraries this project uses (benchmarks/service_floor.py):
- `floor_raw`: the first phase's raw request sent to a bare queryable on a literal key, in a service
  node's process, that only reads and checks the request with the service's own reader, runs `World.move`
  and writes the State with the service's packer (no stats, queue, engine lock, records or publication);
- `floor_move`: the same queryable asked by the least client (`floor_client_move`: the move map packed by
  msgspec, the key declared on the session, the State read by the client library's own reader).
`floor_move - floor_bound` is what the protocol itself costs over the bound; `move - bound` less that is
what the service's and the client library's own work add. The phase runs after the first, so that the
target's three series are asked as before with nothing of the floor's running beside them; the launch then
stops everything and prints the six medians.

Two trees compared (`launch_pairs`): launches of each, alternated pair by pair (A then B, then B then A),
each figure's difference paired launch by launch. Two copies of one tree, identical in all a launch runs,
compared so, differed by 2 to 4 µs over the bound on the project's VM (one copy lower in 32 of 42 pairs; the cause not found: not
the page cache alone). So compare a tree with a copy of itself first, and read a change's difference against
that; a difference of a few µs between two trees is not a change's unless it stands out of it.

    python3 -m benchmarks.round_trip_launches [LAUNCHES]        (and ONE_CORE_LAUNCHES on one core)
    python3 -m benchmarks.round_trip_launches pairs TREE_A TREE_B [PAIRS [CPU]]
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from . import common
from .common import log
from .service_harness import child_env

__all__ = ["LAUNCHES", "ONE_CORE_LAUNCHES", "REQUESTS", "launch_pairs", "one_core", "over_bound", "paired",
           "round_trip_launches"]

#: launches of the whole set of processes (odd: the median is one launch's figure)
LAUNCHES = 21
#: launches with every process pinned to one core (a steadier reading beside the target's)
ONE_CORE_LAUNCHES = 11
#: requests of each series in a launch (a multiple of the six orders of three series)
REQUESTS = 1200
#: the longest a launch may take (start-ups, warm-ups, 6 x REQUESTS round trips, stops)
LAUNCH_TIMEOUT_S = 300


def over_bound(launch: dict[str, float]) -> dict[str, float]:
    """One launch's medians (µs) as what the service and the client library add over the bound, and (when
    the launch measured it) what the protocol's floor adds over the bound of its own phase."""
    bound, raw, move = launch["engine_echo"], launch["raw_move"], launch["move"]
    out = {"over_bound": move - bound, "service": raw - bound, "client": move - raw}
    if "floor_move" in launch:
        floor_bound, floor_raw, floor_move = launch["floor_bound"], launch["floor_raw"], launch["floor_move"]
        out.update({"floor_over_bound": floor_move - floor_bound, "floor_service": floor_raw - floor_bound,
                    "floor_client": floor_move - floor_raw})
    return out


def summarise(launches: list[dict[str, float]]) -> dict[str, Any]:
    """The launches' medians, each one's figures over the bound, and the median, quartiles and range of those."""
    each = [over_bound(m) for m in launches]
    out: dict[str, Any] = {"launches": launches, "over_bound_each": each}
    for key in ("over_bound", "service", "client", "floor_over_bound", "floor_service", "floor_client"):
        values = [e[key] for e in each if key in e]
        if len(values) < len(each):  # launches recorded before the floor was measured
            continue
        q1, _, q3 = statistics.quantiles(values, n=4, method="inclusive") if len(values) > 1 else values * 3
        out[key] = {"median": statistics.median(values), "min": min(values), "max": max(values), "q1": q1, "q3": q3}
    return out


def one_core() -> int:
    """The core the one-core launches run on: the lowest this process may run on."""
    return min(os.sched_getaffinity(0))


def launch_main(requests: int, cpu: int | None = None) -> None:
    """One launch: the service and the bound started, the three series asked in every order; then, the service
    stopped, the protocol's floor started and asked against the same bound in every order; everything stopped.
    With `cpu`, this process and every process it starts run on that core alone."""
    if cpu is not None:
        os.sched_setaffinity(0, {cpu})  # before any thread or child: all of them inherit it
    import zenoh

    from clients import Client
    from service.bus.zconfig import make_config

    from .bench_service import move_requests, one_move_series
    from .service_floor import FLOOR_EXACT_KEY, floor_client_move
    from .service_harness import Child, bench_walker, free_port, scene_file, start_position

    endpoint, bound_endpoint = f"tcp/127.0.0.1:{free_port()}", f"tcp/127.0.0.1:{free_port()}"
    floor_port = free_port()
    service = Child([sys.executable, "-m", "service", "--scene", str(scene_file()), "--listen", endpoint,
                     "--log-level", "WARNING", "--queue", "4096"], "acphys service ready")
    bound: Child | None = None
    floor: Child | None = None
    cpus = set(os.sched_getaffinity(service.proc.pid))  # the cores the launch's processes were allowed, read from each
    try:
        bound = Child([sys.executable, "-m", "benchmarks.bench_service", "engine-echo",
                       bound_endpoint.rsplit(":", 1)[1]], "engine echo ready")
        cpus |= os.sched_getaffinity(bound.proc.pid)
        with zenoh.open(make_config(connect=[bound_endpoint])) as b:
            with Client([endpoint], timeout=30.0) as c:
                mid = c.register(bench_walker(), start_position(0)).id
                got = _asked(one_move_series(b, c, mid, c.keys.move(start_position(0).landblock), move_requests(mid)),
                             requests)
            # the second phase alone with the bound, as the first was: the service's process gone
            service.stop()
            floor = Child([sys.executable, "-m", "benchmarks.service_floor", str(floor_port)], "floor ready")
            cpus |= os.sched_getaffinity(floor.proc.pid)
            with Client([f"tcp/127.0.0.1:{floor_port}"], timeout=30.0) as fc:
                floor_mid = fc.register(bench_walker(), start_position(0)).id
                # the first phase's bound and raw request, the raw request sent to the floor's literal key
                lean = one_move_series(b, fc, floor_mid, FLOOR_EXACT_KEY, move_requests(floor_mid))
                floor_got = _asked({"engine_echo": lean["engine_echo"], "floor_raw": lean["raw_move"],
                                    "floor_move": floor_client_move(fc.session, FLOOR_EXACT_KEY, floor_mid)}, requests)
    finally:
        for child in (service, bound, floor):
            if child is not None:
                child.stop()
    medians: dict[str, Any] = {name: s["median"] for name, s in got.items()}
    medians.update({"floor_bound": floor_got["engine_echo"]["median"], "floor_raw": floor_got["floor_raw"]["median"],
                    "floor_move": floor_got["floor_move"]["median"], "cpus": sorted(cpus | os.sched_getaffinity(0))})
    print("LAUNCH " + json.dumps(medians), flush=True)


def _asked(series: dict[str, Callable[[int], Any]], requests: int) -> dict[str, dict[str, float]]:
    """`series` warmed (every route; a session meets a queryable only after it opens), then asked in every order."""
    for i in range(100):
        for ask in series.values():
            ask(i)
    return common.round_trips_in_every_order(series, requests)


def _launch(engine_root: Path | None, requests: int, cpu: int | None = None) -> dict[str, Any]:
    """One launch in a child process: each series' median (µs), and `cpus`, the cores its processes could use."""
    pinned = [] if cpu is None else [str(cpu)]
    p = subprocess.run([sys.executable, "-m", "benchmarks.round_trip_launches", "launch", str(requests), *pinned],
                       cwd=engine_root or common.ROOT, env=child_env(engine_root), capture_output=True, text=True,
                       timeout=LAUNCH_TIMEOUT_S)
    lines = [ln for ln in p.stdout.splitlines() if ln.startswith("LAUNCH ")]
    if p.returncode != 0 or not lines:
        raise RuntimeError(f"round-trip launch failed ({p.returncode}):\n{p.stderr[-2000:]}")
    medians: dict[str, Any] = json.loads(lines[-1][7:])
    return medians


def round_trip_launches(engine_root: Path | None = None, launches: int = LAUNCHES,
                        requests: int = REQUESTS, cpu: int | None = None) -> dict[str, Any]:
    """`launches` launches one after the other (each alone on the machine), summarised; with `cpu`, every
    process of each launch on that core alone (`cpu` recorded)."""
    got = []
    where = "" if cpu is None else f" on core {cpu} alone"
    for i in range(launches):
        launch = _launch(engine_root, requests, cpu)
        launch.pop("cpus", None)
        got.append(launch)
        e = over_bound(launch)
        log(f"service: round trip{where}, launch {i + 1} of {launches}: Client.move {e['over_bound']:+.1f} µs over the "
            f"bound (the service {e['service']:+.1f}, the client library {e['client']:+.1f})")
    out = summarise(got)
    out["requests"] = requests  # of each series in each launch
    if cpu is not None:
        out["cpu"] = cpu
    m = out["over_bound"]
    log(f"service: round trip{where} over the bound, median of {launches} launches {m['median']:+.1f} µs "
        f"(quartiles {m['q1']:+.1f} to {m['q3']:+.1f}, launches {m['min']:+.1f} to {m['max']:+.1f})")
    return out


def paired(pairs: list[tuple[dict[str, float], dict[str, float]]]) -> dict[str, dict[str, float]]:
    """Launch pairs (tree A's launch, tree B's) as each figure over the bound (`over_bound`): each tree's median,
    and B - A pair by pair: the differences' median and mean, and in how many pairs B's was lower."""
    figures = [(over_bound(x), over_bound(y)) for x, y in pairs]
    out: dict[str, dict[str, float]] = {}
    for key in ("over_bound", "service", "client", "floor_over_bound"):
        if not figures or any(key not in x or key not in y for x, y in figures):
            continue  # no pairs, or launches recorded before the floor was measured
        a, b = [x[key] for x, _ in figures], [y[key] for _, y in figures]
        differences = [y - x for x, y in zip(a, b)]
        out[key] = {"a": statistics.median(a), "b": statistics.median(b),
                    "difference": statistics.median(differences), "mean": statistics.mean(differences),
                    "b_lower": sum(d < 0 for d in differences), "pairs": len(differences)}
    return out


def launch_pairs(tree_a: Path, tree_b: Path, pairs: int, requests: int = REQUESTS,
                 cpu: int | None = None) -> dict[str, Any]:
    """`pairs` launches of each tree (their own benchmarks, service, client library and engine), alternately
    first, each pair's figures paired (`paired`); with `cpu`, every launch on that core alone."""
    got: list[tuple[dict[str, float], dict[str, float]]] = []
    for i in range(pairs):
        order = (tree_a, tree_b) if i % 2 == 0 else (tree_b, tree_a)
        first, second = (_launch(tree, requests, cpu) for tree in order)
        a, b = (first, second) if i % 2 == 0 else (second, first)
        got.append((a, b))
        log(f"service: launch pair {i + 1} of {pairs}: Client.move over the bound, A {over_bound(a)['over_bound']:+.1f} "
            f"µs, B {over_bound(b)['over_bound']:+.1f} µs")
    summary = paired(got)
    out = {"tree_a": str(tree_a), "tree_b": str(tree_b), "requests": requests, "pairs": got, "paired": summary}
    if got:
        d = summary["over_bound"]
        log(f"service: B - A over the bound, paired median {d['difference']:+.1f} µs (mean {d['mean']:+.1f}), B lower in "
            f"{d['b_lower']} of {d['pairs']} pairs")
    return out


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "launch":
        launch_main(int(sys.argv[2]), int(sys.argv[3]) if len(sys.argv) > 3 else None)
    elif len(sys.argv) > 3 and sys.argv[1] == "pairs":
        print(json.dumps(launch_pairs(Path(sys.argv[2]).resolve(), Path(sys.argv[3]).resolve(),
                                      int(sys.argv[4]) if len(sys.argv) > 4 else LAUNCHES, REQUESTS,
                                      int(sys.argv[5]) if len(sys.argv) > 5 else None), indent=1))
    else:
        print(json.dumps({"launches": round_trip_launches(launches=int(sys.argv[1]) if len(sys.argv) > 1 else LAUNCHES),
                          "one_core": round_trip_launches(launches=ONE_CORE_LAUNCHES, cpu=one_core())}, indent=1))
