"""Many movers: what each held mover costs a service, as the count grows to sixteen thousand.

A service node (service/bus/node.py) runs in this process on the flat benchmark scene, its collector tuned
as `serve` tunes it (service/heap.py), with a watcher: a process of its own (as any subscriber is; in this
process its callbacks would take the GIL from the timed thread) that subscribes over loopback to every
State (`P/obj/*/state`), and at times to every error (`P/obj/*/error`), and counts what it receives.
Players (who walk through each other) are registered on a 1.5 m grid in one landblock, straight into the
node's ServiceCore on this thread, as the engine thread would. At each checkpoint (1,000, 4,096 and 16,384
movers) the engine thread's cost is timed:

- a register: the last `SAMPLE` registers before the checkpoint, each on its own; and as many more with
  the State publication off (no State key declared), removed again;
- a pushed move, for `SAMPLE` movers spread over the crowd, in one push: with their States published on
  their declared keys, and with the publication off, `MOVE_REPEATS` pushes of each, alternately (the
  median of each). An untimed push of the same movers comes first: their
  records are cold after the registers, the more so the more movers there are (without it, the first
  timed push paid for that, which read as a publication growing with the crowd);
- a push of `SAMPLE` failing moves, per move: unknown ids with nobody subscribed to an error key, the same
  with the watcher subscribed, and held movers' (an infinite offset) with the watcher subscribed, their
  second push (the first declares their error keys);
- the process's RSS.

And beside them, Zenoh alone on the node's session: declaring a new key under `P/obj`, a put on an
undeclared key there, and a put on a mover's declared State key. Zenoh walks the keys declared beside an
undeclared key at each put, and beside a new key at its declaration (service/bus/route_keys.py).

Bounded: loopback only, fixed counts.
"""

from __future__ import annotations

import gc
import json
import statistics
import sys
import threading
import time
from functools import partial
from typing import Any

from .common import log
from .service_harness import Child, bench_walker, free_port, scene_file

#: the checkpoints (movers held), and the quick run's
COUNTS = (1000, 4096, 16384)
QUICK_COUNTS = (200, 1000)
#: registers, moves and failing moves timed at each checkpoint
SAMPLE = 256
QUICK_SAMPLE = 64
#: pushes of the spread movers with their States published, and as many without, alternately
MOVE_REPEATS = 5
#: an id no mover has: the failing pushes' unknown ids start here
UNKNOWN_BASE = 0x7E000000
#: the grid the movers stand on (players walk through each other, so the spacing is only for realism)
GRID_COLUMNS, GRID_SPACING, GRID_ORIGIN = 120, 1.5, 6.0


def _rss_bytes() -> int:
    with open("/proc/self/status", encoding="ascii") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) * 1024
    return 0


class _Counter:
    """Samples received by the watcher, counted by the key's last chunk (on Zenoh's threads)."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.counts: dict[str, int] = {}

    def __call__(self, sample: Any) -> None:
        kind = str(sample.key_expr).rsplit("/", 1)[-1]
        with self.lock:
            self.counts[kind] = self.counts.get(kind, 0) + 1

    def snapshot(self) -> dict[str, int]:
        with self.lock:
            return dict(self.counts)


def watch_main(endpoint: str, prefix: str) -> None:
    """The watcher process: subscribes to every State and counts what it receives. It answers queries on
    `P/bench/watcher`: `count` (the counts so far, as JSON), `errors on` and `errors off` (subscribe to every
    error key, or stop). Serves until SIGINT."""
    import zenoh

    from service.bus.zconfig import make_config

    from .service_harness import stop_event

    stop = stop_event()
    session = zenoh.open(make_config(connect=[endpoint]))  # the service's own defaults, as its tests' sessions
    counter = _Counter()
    subscribers = {"state": session.declare_subscriber(f"{prefix}/obj/*/state", counter)}

    def on_query(query: Any) -> None:
        command = query.payload.to_bytes() if query.payload is not None else b"count"
        if command == b"errors on" and "error" not in subscribers:
            subscribers["error"] = session.declare_subscriber(f"{prefix}/obj/*/error", counter)
        elif command == b"errors off" and "error" in subscribers:
            subscribers.pop("error").undeclare()
        query.reply(query.key_expr, json.dumps(counter.snapshot()))

    queryable = session.declare_queryable(f"{prefix}/bench/watcher", on_query)
    print("WATCHING", flush=True)
    stop.wait()
    queryable.undeclare()
    session.close()


def _wait(predicate: Any, timeout: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.01)
    return bool(predicate())


def run(quick: bool = False) -> dict[str, Any]:
    from engine import load_scene
    from engine.geometry import Position, Vec3
    from service.bus.node import NodeOptions, ServiceNode
    from service.bus.zconfig import make_config
    from service.protocol.codec import encode_mover_spec, encode_position
    from service.protocol.requests import parse_moves, parse_register

    from .scenes import LB, cell_at

    counts = QUICK_COUNTS if quick else COUNTS
    sample = QUICK_SAMPLE if quick else SAMPLE
    where = f"tcp/127.0.0.1:{free_port()}"
    # the collector tuned as a serving process has it (service/heap.py), and given back as it was after
    gc_threshold = gc.get_threshold()
    node = ServiceNode(load_scene(str(scene_file())), make_config(listen=[where]), NodeOptions(tune_heap=True))
    try:
        node.start()
    except Exception:
        gc.set_threshold(*gc_threshold)
        raise
    core, bus, session = node.core, node.bus, node.session
    assert core is not None and bus is not None and session is not None
    prefix = node.options.prefix
    try:
        watcher = Child([sys.executable, "-m", "benchmarks.bench_many_movers", "watch", where, prefix], "WATCHING")
    except Exception:
        node.shutdown(timeout=10.0)
        gc.set_threshold(*gc_threshold)
        raise

    def ask(command: bytes) -> dict[str, int]:
        """The watcher's counts, after `command`."""
        for reply in session.get(f"{prefix}/bench/watcher", payload=command, timeout=10.0):
            if reply.ok is not None:
                return dict(json.loads(reply.ok.payload.to_bytes()))
        raise RuntimeError(f"the watcher did not answer {command!r}")

    def received(kind: str, count: int) -> bool:
        return ask(b"count").get(kind, 0) >= count
    spec = encode_mover_spec(bench_walker())
    movers: list[int] = []
    rows: list[dict[str, Any]] = []
    unknown = UNKNOWN_BASE

    def register_one(into: list[int]) -> float:
        i = len(movers)
        x = GRID_ORIGIN + GRID_SPACING * (i % GRID_COLUMNS)
        y = GRID_ORIGIN + GRID_SPACING * ((i // GRID_COLUMNS) % GRID_COLUMNS)
        req = parse_register({"v": 1, "mover": spec, "position": encode_position(Position.at(cell_at(LB, x, y),
                                                                                               Vec3(x, y, 50.0)))})
        t0 = time.perf_counter()
        into.append(int(core.register(req)["state"]["id"]))
        return time.perf_counter() - t0

    def push_ms_each(items: list[dict[str, Any]]) -> float:
        msg = {"v": 1, "moves": items}
        batch = parse_moves(msg)
        t0 = time.perf_counter()
        core.push(batch, items, time.monotonic())
        return (time.perf_counter() - t0) / len(items) * 1e3

    def zenoh_declare_us(keys: list[str]) -> float:
        t0 = time.perf_counter()
        declared = [session.declare_keyexpr(k) for k in keys]
        spent = time.perf_counter() - t0
        for kx in declared:
            session.undeclare(kx)
        return spent / len(keys) * 1e6

    def zenoh_put_us(keys: list[Any]) -> float:
        t0 = time.perf_counter()
        for k in keys:
            session.put(k, b"x")
        return (time.perf_counter() - t0) / len(keys) * 1e6

    try:
        if not _wait(bus.states_watched):
            raise RuntimeError("the watcher's State subscription never reached the node")
        for n in counts:
            log(f"many movers: registering up to {n}")
            while len(movers) < n - sample:
                register_one(movers)
            register_s = [register_one(movers) for _ in range(sample)]
            # registers published nowhere (no State key declared: what the engine and the core cost), removed again
            bus.publish_states = False
            quiet: list[int] = []
            register_quiet_s = [register_one(quiet) for _ in range(sample)]
            bus.publish_states = True
            for m in quiet:
                core.remove(m)
            rss = _rss_bytes()
            spread = movers[:: max(1, len(movers) // sample)][:sample]
            states_expected = ask(b"count").get("state", 0) + MOVE_REPEATS * len(spread)
            # the same movers three times: untimed first (their records are cold after the registers, more so
            # the more there are), then with their States published, then published nowhere (what the engine
            # and the core cost)
            bus.publish_states = False
            push_ms_each([{"id": m, "offset": [0.2, 0.0, 0.0]} for m in spread])
            published: list[float] = []
            unpublished: list[float] = []
            for _ in range(MOVE_REPEATS):  # alternately, back and forth: the medians
                bus.publish_states = True
                published.append(push_ms_each([{"id": m, "offset": [-0.2, 0.0, 0.0]} for m in spread]))
                bus.publish_states = False
                unpublished.append(push_ms_each([{"id": m, "offset": [0.2, 0.0, 0.0]} for m in spread]))
            bus.publish_states = True
            move_ms, unpublished_ms = statistics.median(published), statistics.median(unpublished)
            # every pushed move's State was put and reached the watcher: the figure is of real publications
            if not _wait(partial(received, "state", states_expected)):
                raise RuntimeError("the watcher did not receive every pushed move's State")
            unknowns = [{"id": unknown + k, "offset": [0.2, 0.0, 0.0]} for k in range(sample)]
            unknown += sample
            unwatched_ms = push_ms_each(unknowns)
            errors_expected = ask(b"errors on").get("error", 0) + 3 * sample
            if not _wait(bus.errors_watched):
                raise RuntimeError("the watcher's error subscription never reached the node")
            unknowns = [{"id": unknown + k, "offset": [0.2, 0.0, 0.0]} for k in range(sample)]
            unknown += sample
            watched_unknown_ms = push_ms_each(unknowns)
            failing = [{"id": m, "offset": [float("inf"), 0.0, 0.0]} for m in spread]
            held_first_ms = push_ms_each(failing)
            held_ms = push_ms_each(failing)
            if not _wait(partial(received, "error", errors_expected)):
                raise RuntimeError("the watcher did not receive every watched error")
            ask(b"errors off")
            if not _wait(lambda: not bus.errors_watched()):
                raise RuntimeError("the node still sees an error subscriber")
            fresh = [f"{prefix}/obj/{unknown + k:X}/note" for k in range(sample)]
            unknown += sample
            undeclared = [f"{prefix}/obj/{unknown + k:X}/note" for k in range(sample)]
            unknown += sample
            # the movers' own State keys, declared again (a second name for the same key): the watcher receives these
            declared = [session.declare_keyexpr(f"{prefix}/obj/{m:X}/state") for m in spread]
            rows.append({
                "movers": n, "rss_bytes": rss,
                "register_ms": statistics.median(register_s) * 1e3,
                "register_unpublished_ms": statistics.median(register_quiet_s) * 1e3,
                "move_ms": move_ms,
                "move_unpublished_ms": unpublished_ms,
                "error_unwatched_unknown_ms": unwatched_ms,
                "error_watched_unknown_ms": watched_unknown_ms,
                "error_watched_held_first_ms": held_first_ms,
                "error_watched_held_ms": held_ms,
                "zenoh_declare_us": zenoh_declare_us(fresh),
                "zenoh_put_undeclared_us": zenoh_put_us(undeclared),
                "zenoh_put_declared_us": zenoh_put_us(declared),
            })
            for kx in declared:
                session.undeclare(kx)
            log(f"many movers: {rows[-1]}")
        counts_received = ask(b"count")
    finally:
        watcher.stop()
        node.shutdown(timeout=10.0)
        gc.unfreeze()
        gc.set_threshold(*gc_threshold)
    return {"sample": sample, "move_repeats": MOVE_REPEATS, "rows": rows, "received": counts_received}


def per_mover_kb(rows: list[dict[str, Any]]) -> list[float | None]:
    """The RSS each mover added between one checkpoint and the one before (KB; None for the first)."""
    out: list[float | None] = [None]
    for a, b in zip(rows, rows[1:]):
        out.append((b["rss_bytes"] - a["rss_bytes"]) / (b["movers"] - a["movers"]) / 1024)
    return out


def section(data: dict[str, Any], meta: str) -> list[str]:
    """The report's section (benchmarks/report.py); `meta` its line on how it was measured."""
    rows = data["rows"]
    out = ["## Many movers: what each held mover costs the service", "", meta, "",
           "One service node in the benchmark's process (its collector tuned as `serve` tunes it), a watcher in a "
           "process of its own over loopback, players registered straight into the node's core, 1.5 m apart in "
           "one landblock (benchmarks/bench_many_movers.py). Each figure is the engine thread's time, per register "
           f"or per move, over {data['sample']} of them at that count (the median for registers; for moves, which "
           f"run as one push, the mean of a push, the median of {data.get('move_repeats', 1)} pushes); every State and watched error counted here reached the watcher. "
           "\"Published nowhere\" is the same work with the State publication off: no State key declared, no put, "
           "as for a register or a move while nobody subscribes to a State key.",
           "",
           "| movers held | register (ms) | register, published nowhere (ms) | pushed move + State (ms) | the same "
           "move, published nowhere (ms) | RSS (MB) | RSS per mover since the row above (KB) |",
           "|---:|---:|---:|---:|---:|---:|---:|"]
    for r, kb in zip(rows, per_mover_kb(rows)):
        out.append(f"| {r['movers']:,} | {r['register_ms']:.2f} | {r['register_unpublished_ms']:.2f} | "
                   f"{r['move_ms']:.3f} | {r['move_unpublished_ms']:.3f} | {r['rss_bytes'] / 2**20:.0f} | "
                   f"{'-' if kb is None else f'{kb:.1f}'} |")
    out += ["", "Pushed moves that fail (ms each): unknown ids, or held movers' infinite offsets (their second push; "
            "the first declares their error keys). And Zenoh alone on the node's session (µs each): declaring a new "
            "key under `P/obj`, as a register does for its mover's State key; a put on an undeclared key there, "
            "which nobody receives; a put on a mover's declared State key, which the watcher receives.", "",
            "| movers held | failing move, nobody subscribed | unknown id, subscribed | held mover, subscribed | "
            "Zenoh: declare a key | put, undeclared key | put, declared key |", "|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        out.append(f"| {r['movers']:,} | {r['error_unwatched_unknown_ms']:.3f} | {r['error_watched_unknown_ms']:.3f} | "
                   f"{r['error_watched_held_ms']:.3f} | {r['zenoh_declare_us']:.1f} | "
                   f"{r['zenoh_put_undeclared_us']:.1f} | {r['zenoh_put_declared_us']:.1f} |")
    first, last = rows[0], rows[-1]

    def times(key: str) -> str:
        return f"{last[key] / first[key]:.1f}x"

    def publication_us(r: dict[str, Any]) -> float:
        return (r["move_ms"] - r["move_unpublished_ms"]) * 1e3

    out += ["", f"From {first['movers']:,} to {last['movers']:,} movers ({last['movers'] / first['movers']:.1f}x):",
            f"- a register took {times('register_ms')} as long, {last['register_ms']:.2f} ms, and "
            f"{last['register_unpublished_ms']:.2f} ms published nowhere; Zenoh's declaration of one more key, "
            f"measured alone, took {last['zenoh_declare_us'] / 1e3:.2f} ms ({times('zenoh_declare_us')});",
            f"- publishing a pushed move's State added {publication_us(first):.0f} µs at the first count and "
            f"{publication_us(last):.0f} µs at the last; the move published nowhere took "
            f"{times('move_unpublished_ms')} as long;",
            f"- an unknown id's error, with someone subscribed, took {times('error_watched_unknown_ms')} as long, "
            f"{last['error_watched_unknown_ms']:.2f} ms: it is put on a key declared for it alone, whose declaration "
            f"grew as above, where a put on an undeclared key took {last['zenoh_put_undeclared_us'] / 1e3:.2f} ms "
            f"({times('zenoh_put_undeclared_us')}); a held mover's took "
            f"{first['error_watched_held_ms'] * 1e3:.0f} and {last['error_watched_held_ms'] * 1e3:.0f} µs, a put on a "
            f"declared key {first['zenoh_put_declared_us']:.1f} and {last['zenoh_put_declared_us']:.1f} µs.", "",
            "Why: Zenoh matches a key it has not seen declared against every key declared beside it, at each put "
            "on it and once at its declaration (service/bus/route_keys.py). A held mover's States and errors go "
            "on keys declared once; a register pays its State key's declaration, and so does an unknown id's "
            "error, whose key is declared for its put alone (service/bus/publication.py, `publish_error`); a "
            "failing move nobody subscribes to is not put at all.", ""]
    return out


if __name__ == "__main__" and sys.argv[1:2] == ["watch"]:
    watch_main(sys.argv[2], sys.argv[3])
