"""Service benchmark over loopback, bounded in count and time.

- round trip of one move, and of batches of 10 and 100 moves (client library
  `Client.move` / `Client.move_many` against `python -m service`);
- the floor: a bare Zenoh echo queryable in its own process, queried with a
  payload of the same size the same way (peer mode, loopback TCP), measured
  in the same run, interleaved block by block with the service round trips;
- throughput with 1, 2 and 4 client processes (single moves and batches of
  100), and the service process's CPU time per move (from /proc), each
  client's own CPU time per move; batches both with `Client.move_many`
  (every reply entry decoded into a MoverState) and with the lean
  `Client.move_many_maps` (the reply's msgpack decoded into maps; the
  client reads each entry's error/landblock fields, nothing more); and,
  since the service skips publishing States nobody subscribes to, again
  with a subscriber process on every state key and on `P/states` (it
  counts what arrives), the batches sent with `"publish": "each"` (one
  publication per move, the default) or `"batch"` (one per request);
- throughput of one service with 1 and 2 engine processes (`--workers`), the
  same batched workload (4 client processes, batches of 100, their movers
  spread over two landblocks that `--workers 2` gives to different workers),
  with each side's CPU use in cores (service: the parent router and its
  workers; clients: their own CPU time). `python3 -m benchmarks.bench_service
  workers --workers 1,2,4 --clients 8` repeats it on a bigger machine;
- the service's own handling of one move without the network (its query
  callback called with a stand-in query, in a child process), back to back
  and with idle gaps between moves as in a round trip: on this machine the
  same code runs several times slower after the CPU has been idle or busy
  with other processes, which the round trips pay and the echo hardly does.

Everything listens on 127.0.0.1 on free ports; every process is stopped at
the end, every loop ends after a fixed count or a fixed time.
"""

from __future__ import annotations

import contextlib
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from collections.abc import Callable
from typing import Any

from . import common
from .common import log, round_trips_in_every_order, summary
from .service_harness import (Child, bench_walker, child_env, collect_reports, free_port,
                              scene_file, start_position, stop_event)
from .standins import NoEngine, StandInQuery, StandInSession

ECHO_KEY = "acphys-bench/echo"
ENGINE_ECHO_KEY = "acphys-bench/engine-echo"


# -- the bare echo ------------------------------------------------------------------------------
def echo_main(port: int) -> None:
    """Run a queryable that answers every query with its own payload, until SIGINT/SIGTERM."""
    import zenoh

    from service.bus.zconfig import make_config

    stop = stop_event()
    session = zenoh.open(make_config(listen=[f"tcp/127.0.0.1:{port}"]))

    def handler(query: Any) -> None:
        payload = query.payload
        query.reply(query.key_expr, payload.to_bytes() if payload is not None else b"")

    q = session.declare_queryable(ECHO_KEY, handler)
    print("echo ready", flush=True)
    stop.wait()
    q.undeclare()
    session.close()


def engine_echo_handler(world: Any, engine_id: int) -> Callable[[Any], None]:
    """The bound's answer to one move query: the request (the service's own one-move message) read with
    msgpack and nothing checked, `World.move` of mover `engine_id` from where it last ended, and the result's
    cell, origin, orientation and contact bits in one msgpack array (a State says more)."""
    import msgpack

    from engine.geometry import Vec3

    last = [world.mover_state(engine_id).position]

    def handler(query: Any) -> None:
        x, y, z = msgpack.unpackb(query.payload.to_bytes())["move"]["offset"]
        r = world.move(engine_id, last[0].moved(Vec3(x, y, z)))
        p = last[0] = r.position
        o, q = p.frame.origin, p.frame.orientation
        query.reply(query.key_expr, msgpack.packb([p.cell_id, o.x, o.y, o.z, q.w, q.x, q.y, q.z, r.contact,
                                                   r.on_walkable]))

    return handler


def move_requests(mover_id: int) -> list[bytes]:
    """The service's one-move message for `mover_id`, packed: 0.2 m east, and back (requests alternate them)."""
    import msgpack

    from clients import Move

    return [msgpack.packb({"v": 1, "move": Move(mover_id, offset=(d, 0.0, 0.0)).to_wire()}, use_bin_type=True)
            for d in (0.2, -0.2)]


def one_move_series(bound: Any, client: Any, mover_id: int, move_key: str,
                    raw_moves: list[bytes]) -> dict[str, Callable[[int], Any]]:
    """The one-move comparison's three series, for common.round_trips_in_every_order: the bound (a plain `get`
    on `bound`, a session to engine_echo_main's queryable), the raw move request (a plain `get` of `raw_moves`,
    the service's one-move messages, on the client's session) and `Client.move` of `mover_id`, each request
    alternately 0.2 m east and back."""
    offsets = [(0.2, 0.0, 0.0), (-0.2, 0.0, 0.0)]
    return {"engine_echo": lambda i: list(bound.get(ENGINE_ECHO_KEY, payload=raw_moves[i % 2], timeout=10.0)),
            "raw_move": lambda i: list(client.session.get(move_key, payload=raw_moves[i % 2], timeout=10.0)),
            "move": lambda i: client.move(mover_id, offset=offsets[i % 2])}


def engine_echo_main(port: int) -> None:
    """Run a bare queryable that moves one mover per query, until SIGINT/SIGTERM: the least any service of
    this engine does for one move over this bus (the one-move round trip's bound). The engine is the working
    tree's, on the service benchmark's scene, one mover of the service's; the answer `engine_echo_handler`'s."""
    import zenoh

    from service.world_source import open_world
    from service.bus.zconfig import make_config

    stop = stop_event()
    world = open_world(scene=str(scene_file()))
    engine_id = world.add_mover(bench_walker(), start_position(0), None, None)
    session = zenoh.open(make_config(listen=[f"tcp/127.0.0.1:{port}"]))
    handler = engine_echo_handler(world, engine_id)

    q = session.declare_queryable(ENGINE_ECHO_KEY, handler)
    print("engine echo ready", flush=True)
    stop.wait()
    q.undeclare()
    session.close()


# -- throughput workers (own processes) -------------------------------------------------------------
CLIENT_MODES = {
    "objects": "Client.move_many: every entry decoded into a MoverState",
    "maps": "Client.move_many_maps: entries as decoded msgpack maps; errors counted, landblocks learned",
}


def worker_main(endpoint: str, index: int, batch: int, start_at: float, seconds: float, mode: str = "objects",
                publish: str = "each", lb: int | None = None) -> None:
    """Register a mover, wait for `start_at` (time.time()), then move it back and
    forth for `seconds` in requests of `batch` moves; print a JSON report (with this
    process's CPU time per move over the timed loop)."""
    from clients import Client, Move

    with Client([endpoint], timeout=30.0) as c:
        mid = c.register(bench_walker(), start_position(index + 10, lb)).id
        c.move(mid, offset=(0.0, 0.0, 0.0))
        time.sleep(max(0.0, start_at - time.time()))
        cpu0 = time.process_time()
        end = time.monotonic() + seconds
        moves = requests = errors = 0
        sign = 1.0
        while time.monotonic() < end:
            if batch == 1:
                c.move(mid, offset=(0.2 * sign, 0.0, 0.0))
            else:
                ms = [Move(mid, offset=(0.2 * (sign if k % 2 else -sign), 0.0, 0.0)) for k in range(batch)]
                if mode == "maps":
                    entries = c.move_many_maps(ms, publish=publish)
                    errors += sum(1 for e in entries if not isinstance(e, dict) or "error" in e)
                else:
                    res = c.move_many(ms, publish=publish)
                    errors += sum(1 for r in res if not hasattr(r, "seq"))
            sign = -sign
            moves += batch
            requests += 1
        elapsed = seconds + (time.monotonic() - end)
        cpu = time.process_time() - cpu0
        c.remove(mid)
    print("RESULT " + json.dumps({"index": index, "moves": moves, "requests": requests, "errors": errors,
                                   "seconds": elapsed, "cpu_seconds": cpu}), flush=True)


def watcher_main(endpoint: str) -> None:
    """Subscribe to every mover's state key and to P/states, count the States that arrive until SIGINT
    (a P/states message's from its array header); print the count."""
    import zenoh

    from service.protocol.frames import states_message
    from service.protocol.wire import Keys
    from service.bus.zconfig import make_config

    stop = stop_event()
    count = [0]

    def on_sample(_sample: Any) -> None:
        count[0] += 1

    head = len(states_message([])) - 1  # {"v": 1, "states": [ ... up to the array header

    def on_states(sample: Any) -> None:
        data = sample.payload.to_bytes()
        h = data[head]
        count[0] += h & 0x0F if h & 0xF0 == 0x90 else int.from_bytes(data[head + 1:head + 3], "big")

    session = zenoh.open(make_config(connect=[endpoint]))
    keys = Keys("acphys")
    subs = [session.declare_subscriber(keys.state("*"), on_sample), session.declare_subscriber(keys.states, on_states)]
    print("watcher ready", flush=True)
    stop.wait()
    for sub in subs:
        sub.undeclare()
    session.close()
    print(f"WATCHED {count[0]}", flush=True)


def throughput(endpoint: str, service: Child, processes: int, batch: int, seconds: float,
               mode: str = "objects", watched: bool = False, publish: str = "each",
               landblocks: tuple[int, ...] = ()) -> dict[str, Any]:
    """Client processes moving one mover each for `seconds`; client i's mover in landblocks[i % n] when given."""
    watcher = Child([sys.executable, "-m", "benchmarks.bench_service", "watcher", endpoint], "watcher ready") \
        if watched else None
    start_at = time.time() + 2.5  # every worker has registered by then (and the watcher's subscription is known)
    procs = [subprocess.Popen([sys.executable, "-m", "benchmarks.bench_service", "worker", endpoint, str(i), str(batch),
                               repr(start_at), repr(seconds), mode, publish,
                               f"{landblocks[i % len(landblocks)]:04X}" if landblocks else "-"],
                              cwd=common.ROOT, env=child_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for i in range(processes)]
    time.sleep(max(0.0, start_at - time.time()))
    cpu0 = service.cpu_seconds()
    try:
        reports = collect_reports(procs, seconds + 60.0, "throughput worker")
        cpu = service.cpu_seconds() - cpu0  # includes the workers' remove requests: negligible
        cpu_wall = time.time() - start_at
    finally:
        received = None
        if watcher is not None:
            watcher.stop()
            deadline = time.monotonic() + 5.0
            while time.monotonic() < deadline and not any(ln.startswith("WATCHED ") for ln in watcher.output):
                time.sleep(0.05)
            got = [int(ln.split()[1]) for ln in watcher.output if ln.startswith("WATCHED ")]
            received = got[-1] if got else None
    moves = sum(r["moves"] for r in reports)
    wall = max(r["seconds"] for r in reports)
    row = {"processes": processes, "batch": batch, "client": mode if batch > 1 else "objects", "watched": watched,
           "publish": publish if batch > 1 else "each",
           "moves": moves, "seconds": wall, "moves_per_s": moves / wall, "errors": sum(r["errors"] for r in reports),
           "service_cpu_us_per_move": cpu / moves * 1e6 if moves else None,
           "client_cpu_us_per_move": sum(r["cpu_seconds"] for r in reports) / moves * 1e6 if moves else None,
           # CPU in cores (CPU seconds per second of the run): what each side takes of the machine
           "service_cores": cpu / cpu_wall, "client_cores": sum(r["cpu_seconds"] for r in reports) / wall,
           "states_received": received}
    log(f"service: {processes} proc x batch {batch:3d} ({row['client']}, publish {row['publish']}"
        f"{', state subscriber' if watched else ''}): "
        f"{row['moves_per_s']:9.0f} moves/s, service CPU {row['service_cpu_us_per_move']:.0f} µs/move, "
        f"client CPU {row['client_cpu_us_per_move']:.0f} µs/move"
        + (f", {received} states received" if watched else ""))
    return row


#: the throughput runs: (client processes, moves per request, client mode, a state subscriber present,
#: the requests' `publish`)
THROUGHPUT_RUNS = [
    *((n, 1, "objects", False, "each") for n in (1, 2, 4)),
    *((n, 100, "objects", False, "each") for n in (1, 2, 4)),
    *((n, 100, "maps", False, "each") for n in (1, 2, 4)),
    (2, 100, "objects", True, "each"),
    (2, 100, "maps", True, "each"),
    (2, 100, "maps", True, "batch"),
]


# -- one service, 1 or more engine processes (`serve --workers N`) -----------------------------------------
WORKERS_CLIENTS = 4
WORKERS_BATCH = 100


def workers_scaling(scene: Path, counts: tuple[int, ...] = (1, 2), clients: int = WORKERS_CLIENTS,
                    seconds: float = 4.0) -> list[dict[str, Any]]:
    """The same batched workload (`clients` processes, batches of 100 read as maps, movers spread over
    landblocks that the largest N gives to different workers) against `serve --workers N` for each N; each
    side's CPU use (cores)."""
    from service.ownership import Ownership
    from service.scaleout.workers import scene_landblocks

    # one landblock of each share of the largest split: every worker gets movers, and each run the same ones
    spread = tuple(min(p.landblocks or ()) for p in Ownership().split(max(counts), scene_landblocks(str(scene))))
    rows = []
    for n in counts:
        endpoint = f"tcp/127.0.0.1:{free_port()}"
        service = Child([sys.executable, "-m", "service", "--scene", str(scene), "--listen", endpoint, "--workers", str(n),
                         "--log-level", "WARNING", "--queue", "4096"], "acphys service ready")
        try:
            row = throughput(endpoint, service, clients, WORKERS_BATCH, seconds, "maps", landblocks=spread)
        finally:
            service.stop()
        row["workers"] = n
        log(f"service: --workers {n}: {row['moves_per_s']:9.0f} moves/s with {clients} client processes; "
            f"service {row['service_cores']:.2f} cores, clients {row['client_cores']:.2f} cores "
            f"({os.cpu_count()} CPUs)")
        rows.append(row)
    return rows


def workers_cli(argv: list[str]) -> None:
    """`python3 -m benchmarks.bench_service workers [--workers 1,2,4] [--clients 8] [--seconds 6]`: the workers
    rows alone, printed as JSON (to repeat on a machine with more cores)."""
    import argparse

    p = argparse.ArgumentParser(prog="python3 -m benchmarks.bench_service workers")
    p.add_argument("--workers", default="1,2", help="worker counts to run (default %(default)s)")
    p.add_argument("--clients", type=int, default=WORKERS_CLIENTS, help="client processes (default %(default)s)")
    p.add_argument("--seconds", type=float, default=4.0, help="seconds per run (default %(default)s)")
    a = p.parse_args(argv)
    rows = workers_scaling(scene_file(), tuple(int(n) for n in a.workers.split(",")), a.clients, a.seconds)
    print(json.dumps(rows, indent=2))


# -- the service's own handling, without the network ---------------------------------------------------
def _client_part(moves: int) -> dict[str, Any]:
    """The client library's part of one move (`Client.move`: the request packed, the State decoded), its
    session replaced by a stand-in that answers with a State as the service packs it."""
    from clients import Client
    from engine.geometry import Position, Vec3
    from engine import MoveResult
    from service.protocol.codec import pack_state
    from service.protocol.frames import state_message

    start = start_position(0)
    result = MoveResult(True, Position.at(start.cell_id, Vec3(20.0, 20.0, 50.0)), "OK", True, True, None,
                        start.cell_id, None, None, False, 0, ["Contact", "OnWalkable"], [])
    client = Client(session=StandInSession(state_message(pack_state(7, 1, result, []))))  # type: ignore[arg-type]
    client.locate(7, start.landblock)
    for _ in range(200):
        client.move(7, offset=(0.2, 0.0, 0.0))
    times = []
    for _ in range(moves):
        t0 = time.perf_counter()
        client.move(7, offset=(0.2, 0.0, 0.0))
        times.append(time.perf_counter() - t0)
    return summary(times, 1e6)


def handling_main(moves: int) -> None:
    """Time the service's move callback with stand-in queries: back to back, then with idle gaps; then back
    to back with the engine replaced by a stand-in (the service's own handling alone: decode, checks,
    stats, publication check, pack, reply); and the client library's part of a move."""
    from service.protocol.codec import encode_mover_spec, encode_position
    from service.bus.node import NodeOptions, ServiceNode
    from service.protocol.requests import parse_register
    from service.world_source import open_world
    from service.bus.zconfig import make_config

    node = ServiceNode(open_world(scene=str(scene_file())), make_config(listen=[f"tcp/127.0.0.1:{free_port()}"]),
                       NodeOptions())
    node.start()
    try:
        core = node.core
        assert core is not None
        start = start_position(0)
        mid = core.register(parse_register({"v": 1, "mover": encode_mover_spec(bench_walker()),
                                            "position": encode_position(start)}))["state"]["id"]
        key = node.keys.move(start.landblock)
        handler: Any = node.lb_queryable("*")  # called with stand-ins for zenoh.Query
        payloads = move_requests(mid)
        for i in range(200):
            handler(StandInQuery(key, payloads[i % 2]))
        out: dict[str, Any] = {}
        for gap in (0.0, 0.0004, 0.002):
            engine0 = node.stats.engine_time.count
            times = []
            for i in range(moves):
                if gap:
                    time.sleep(gap)
                q = StandInQuery(key, payloads[i % 2])
                t0 = time.perf_counter()
                handler(q)
                times.append(time.perf_counter() - t0)
                assert q.replies == 1
            engine = node.stats.engine_time.samples()[engine0 - node.stats.engine_time.count:]
            out[f"gap_{gap * 1e6:.0f}us"] = {"handler": summary(times, 1e6), "engine": summary(engine, 1e6)}
        out["versus_floor"] = _versus_floor(handler, core, key, payloads, moves)
        # the engine replaced: every move resolves to the mover's current state (what the service adds)
        real_world = core.world
        core.world = NoEngine(real_world, core.movers[mid].last)
        times = []
        for i in range(moves):
            q = StandInQuery(key, payloads[i % 2])
            t0 = time.perf_counter()
            handler(q)
            times.append(time.perf_counter() - t0)
            assert q.replies == 1
        core.world = real_world
        out["no_engine"] = {"handler": summary(times, 1e6)}
    finally:
        node.shutdown()
    out["client"] = {"handler": _client_part(moves)}
    print("HANDLING " + json.dumps(out), flush=True)


#: the idle gaps `_versus_floor` asks after: none, and about a round trip's own
VERSUS_FLOOR_GAPS_S = (0.0, 0.0004)


def _versus_floor(handler: Callable[[Any], None], core: Any, key: str, payloads: list[bytes],
                  moves: int) -> dict[str, Any]:
    """The node's move callback and the protocol's floor (benchmarks/service_floor.py's lean handler on the same
    core: read, `World.move`, pack, reply) asked one after the other, alternately first, back to back and after an
    idle gap before each: what the service's own steps cost over the floor's, warm and as a round trip runs them."""
    from .service_floor import lean_move_handler

    lean = lean_move_handler(core)
    out: dict[str, Any] = {}
    for gap in VERSUS_FLOOR_GAPS_S:
        times: dict[str, list[float]] = {"service": [], "floor": []}
        for i in range(moves):
            pair = (("service", handler), ("floor", lean))
            for name, call in pair if i % 2 == 0 else pair[::-1]:
                if gap:
                    time.sleep(gap)
                q = StandInQuery(key, payloads[i % 2])
                t0 = time.perf_counter()
                call(q)
                times[name].append(time.perf_counter() - t0)
                assert q.replies == 1
        out[f"gap_{gap * 1e6:.0f}us"] = {name: summary(t, 1e6) for name, t in times.items()}
    return out


def handling(engine_root: Path | None, moves: int) -> dict[str, Any]:
    p = subprocess.run([sys.executable, "-m", "benchmarks.bench_service", "handling", str(moves)],
                       cwd=engine_root or common.ROOT, env=child_env(engine_root), capture_output=True, text=True,
                       timeout=300)
    lines = [ln for ln in p.stdout.splitlines() if ln.startswith("HANDLING ")]
    if p.returncode != 0 or not lines:
        raise RuntimeError(f"handling run failed ({p.returncode}):\n{p.stderr[-2000:]}")
    out: dict[str, Any] = json.loads(lines[-1][9:])
    for k, v in out.items():
        if k == "no_engine":
            log(f"service: one move handled without the network, engine replaced by a stand-in: median "
                f"{v['handler']['median']:6.1f} µs (the service's own part)")
        elif k == "client":
            log(f"service: the client library's part of one move (Client.move, stand-in session): median "
                f"{v['handler']['median']:6.1f} µs")
        elif k == "versus_floor":
            for gap, both in v.items():
                log(f"service: one move, the service's callback against the protocol's floor, {gap}: "
                    f"{both['service']['median']:6.1f} vs {both['floor']['median']:6.1f} µs")
        else:
            log(f"service: one move handled without the network, {k:9s}: median {v['handler']['median']:6.0f} µs "
                f"(engine {v['engine']['median']:5.0f} µs)")
    return out


# -- latency --------------------------------------------------------------------------------------
#: the user of the service run with accounts beside the plain one (`serve --users`, service/security/accounts.py)
ACCOUNTS_USER, ACCOUNTS_PASSWORD = "bench", "bench-password"


def accounts_users_file(directory: Path) -> Path:
    path = directory / "users.txt"
    path.write_text(f"{ACCOUNTS_USER}:{ACCOUNTS_PASSWORD}\n", encoding="utf-8")
    return path


def latency(endpoint: str, echo_endpoint: str, rounds: int, block: int,
            accounts_endpoint: str | None = None, engine_echo_endpoint: str | None = None,
            floor_endpoint: str | None = None) -> dict[str, Any]:
    import msgpack
    import zenoh

    from clients import Client, Move
    from service.bus.zconfig import make_config

    # health: a bare get the service answers from its callback with no engine (its floor per request);
    # raw_move: the move request as a bare get, no client library (move - raw_move is the client's part);
    # accounts_move: one move to the same service run with accounts, logged in (Zenoh's authentication and
    # access control on every message); engine_echo: the same bare get to a bare queryable that only runs
    # the engine (engine_echo_main: the bound of any service's one move here); floor_*: the same bare get to a
    # service node's process (benchmarks/service_floor.py): a lean handler on a literal key and on a wildcard
    # one, and that node's own move key
    samples: dict[str, list[float]] = {"echo": [], "engine_echo": [], "health": [], "raw_move": [], "move": [],
                                       "batch10": [], "batch100": [], "accounts_move": [], "floor_exact": [],
                                       "floor_wild": [], "floor_move": []}
    clock = time.perf_counter
    with contextlib.ExitStack() as stack:
        c = stack.enter_context(Client([endpoint], timeout=30.0))
        user = None
        if accounts_endpoint is not None:
            user = stack.enter_context(Client([accounts_endpoint], user=ACCOUNTS_USER, password=ACCOUNTS_PASSWORD,
                                              timeout=30.0))
            user_mid = user.register(bench_walker(), start_position(0)).id
        mid = c.register(bench_walker(), start_position(0)).id
        c.move(mid, offset=(0.0, 0.0, 0.0))
        floor: list[tuple[str, Any, list[bytes]]] = []  # (series, key, the two requests) of the floor's process
        if floor_endpoint is not None:
            from .service_floor import FLOOR_EXACT_KEY, FLOOR_WILD_QUERY

            fc = stack.enter_context(Client([floor_endpoint], timeout=30.0))
            floor_mid = fc.register(bench_walker(), start_position(0)).id
            floor_moves = move_requests(floor_mid)
            floor = [("floor_exact", FLOOR_EXACT_KEY, floor_moves), ("floor_wild", FLOOR_WILD_QUERY, floor_moves),
                     ("floor_move", fc.keys.move(start_position(0).landblock), floor_moves)]
        # what one move request looks like on the wire: the echo carries as many bytes
        raw_moves = move_requests(mid)
        probe = raw_moves[0]
        move_key, health_key, health_probe = c.keys.move(start_position(0).landblock), c.keys.health, msgpack.packb({"v": 1})
        echo = zenoh.open(make_config(connect=[echo_endpoint]))
        engine_echo = None if engine_echo_endpoint is None else stack.enter_context(
            zenoh.open(make_config(connect=[engine_echo_endpoint])))
        try:
            for i in range(50):  # warm every route
                list(echo.get(ECHO_KEY, payload=probe, timeout=10.0))
                if engine_echo is not None:
                    list(engine_echo.get(ENGINE_ECHO_KEY, payload=raw_moves[i % 2], timeout=10.0))
                c.move(mid, offset=(0.0, 0.0, 0.0))
                if user is not None:
                    user.move(user_mid, offset=(0.0, 0.0, 0.0))
                for _series, key, payloads in floor:
                    list(fc.session.get(key, payload=payloads[i % 2], timeout=10.0))
            sign = 1.0
            for _round in range(rounds):
                for _ in range(block):
                    t0 = clock()
                    replies = list(echo.get(ECHO_KEY, payload=probe, timeout=10.0))
                    samples["echo"].append(clock() - t0)
                    assert replies and replies[0].ok is not None
                if engine_echo is not None:
                    for i in range(block):
                        t0 = clock()
                        replies = list(engine_echo.get(ENGINE_ECHO_KEY, payload=raw_moves[i % 2], timeout=10.0))
                        samples["engine_echo"].append(clock() - t0)
                        assert replies and replies[0].ok is not None
                for _ in range(block):
                    t0 = clock()
                    replies = list(c.session.get(health_key, payload=health_probe, timeout=10.0))
                    samples["health"].append(clock() - t0)
                    assert replies and replies[0].ok is not None
                for i in range(block):
                    t0 = clock()
                    replies = list(c.session.get(move_key, payload=raw_moves[i % 2], timeout=10.0))
                    samples["raw_move"].append(clock() - t0)
                    assert replies and replies[0].ok is not None
                for series, key, payloads in floor:
                    for i in range(block):
                        t0 = clock()
                        replies = list(fc.session.get(key, payload=payloads[i % 2], timeout=10.0))
                        samples[series].append(clock() - t0)
                        assert replies and replies[0].ok is not None
                for _ in range(block):
                    t0 = clock()
                    c.move(mid, offset=(0.2 * sign, 0.0, 0.0))
                    samples["move"].append(clock() - t0)
                    sign = -sign
                if user is not None:
                    for _ in range(block):
                        t0 = clock()
                        user.move(user_mid, offset=(0.2 * sign, 0.0, 0.0))
                        samples["accounts_move"].append(clock() - t0)
                        sign = -sign
                for size, key, n in ((10, "batch10", max(1, block // 4)), (100, "batch100", max(1, block // 20))):
                    for _ in range(n):
                        ms = [Move(mid, offset=(0.2 * (1 if k % 2 else -1), 0.0, 0.0)) for k in range(size)]
                        t0 = clock()
                        c.move_many(ms)
                        samples[key].append(clock() - t0)
            every_order = round_trips_in_every_order(
                one_move_series(engine_echo, c, mid, move_key, raw_moves) if engine_echo is not None else {},
                rounds * block)
        finally:
            echo.close()
        (stats,) = c.stats()
        c.remove(mid)
        if user is not None:
            user.remove(user_mid)
        if floor:
            fc.remove(floor_mid)
    out: dict[str, Any] = {k: summary(v, 1e6) for k, v in samples.items() if v}
    if every_order:
        out["every_order"] = every_order
    out["ratio_move_to_echo"] = out["move"]["median"] / out["echo"]["median"]
    out["ratio_move_to_echo_p99"] = out["move"]["p99"] / out["echo"]["p99"]
    out["service_engine_ms"] = stats.get("engine_ms")
    out["service_latency_ms"] = stats.get("latency_ms")
    out["probe_bytes"] = len(probe)
    out["ratio_health_to_echo"] = out["health"]["median"] / out["echo"]["median"]
    out["ratio_raw_move_to_echo"] = out["raw_move"]["median"] / out["echo"]["median"]
    if "engine_echo" in out:
        out["ratio_engine_echo_to_echo"] = out["engine_echo"]["median"] / out["echo"]["median"]
    if "accounts_move" in out:
        out["ratio_accounts_move_to_move"] = out["accounts_move"]["median"] / out["move"]["median"]
    for k in ("echo", "engine_echo", "floor_exact", "floor_wild", "floor_move", "health", "raw_move", "move",
              "accounts_move", "batch10", "batch100"):
        if k in out:
            log(f"service: round trip {k:13s} median {out[k]['median']:9.0f} µs  p99 {out[k]['p99']:9.0f} µs  "
                f"(n={out[k]['n']})")
    for k, v in (out.get("every_order") or {}).items():
        log(f"service: round trip {k:13s} median {v['median']:9.0f} µs  p99 {v['p99']:9.0f} µs  "
            f"(n={v['n']}, one request at a time in every order)")
    log(f"service: move / echo = {out['ratio_move_to_echo']:.2f} (health / echo {out['ratio_health_to_echo']:.2f}, "
        f"raw_move / echo {out['ratio_raw_move_to_echo']:.2f})")
    return out


def run(quick: bool, engine_root: Path | None = None) -> dict[str, Any]:
    """The whole service benchmark; with `engine_root`, the service imports the engine found there
    (benchmarks/out/compiled, say) instead of the working tree's."""
    import zenoh  # noqa: F401 - fail early, with a clear message, when zenoh is missing

    scene = scene_file()
    port, echo_port = free_port(), free_port()
    endpoint, echo_endpoint = f"tcp/127.0.0.1:{port}", f"tcp/127.0.0.1:{echo_port}"
    service = Child([sys.executable, "-m", "service", "--scene", str(scene), "--listen", endpoint,
                     "--log-level", "WARNING", "--queue", "4096"], "acphys service ready", engine_root)
    echo: Child | None = None
    accounts: Child | None = None
    engine_echo: Child | None = None
    floor: Child | None = None
    users_dir = tempfile.TemporaryDirectory(prefix="acphys-bench-users-")
    try:
        echo = Child([sys.executable, "-m", "benchmarks.bench_service", "echo", str(echo_port)], "echo ready")
        engine_echo_endpoint = f"tcp/127.0.0.1:{free_port()}"
        engine_echo = Child([sys.executable, "-m", "benchmarks.bench_service", "engine-echo",
                             engine_echo_endpoint.rsplit(":", 1)[1]], "engine echo ready", engine_root)
        floor_port = free_port()
        floor = Child([sys.executable, "-m", "benchmarks.service_floor", str(floor_port)], "floor ready", engine_root)
        accounts_endpoint = f"tcp/127.0.0.1:{free_port()}"
        accounts = Child([sys.executable, "-m", "service", "--scene", str(scene), "--listen", accounts_endpoint,
                          "--log-level", "WARNING", "--queue", "4096",
                          "--users", str(accounts_users_file(Path(users_dir.name)))], "acphys service ready", engine_root)
        lat = latency(endpoint, echo_endpoint, rounds=4 if quick else 20, block=50 if quick else 100,
                      accounts_endpoint=accounts_endpoint, engine_echo_endpoint=engine_echo_endpoint,
                      floor_endpoint=f"tcp/127.0.0.1:{floor_port}")
        accounts.stop()
        engine_echo.stop()
        floor.stop()
        accounts = engine_echo = floor = None
        lat["handling_us"] = handling(engine_root, 300 if quick else 1000)
        seconds = 2.0 if quick else 8.0
        rows = [throughput(endpoint, service, procs, batch, seconds, mode, watched, publish)
                for procs, batch, mode, watched, publish in THROUGHPUT_RUNS]
    finally:
        service.stop()
        for child in (echo, accounts, engine_echo, floor):
            if child is not None:
                child.stop()
        users_dir.cleanup()
    from .bench_batches import batch_workload
    from .round_trip_launches import LAUNCHES, ONE_CORE_LAUNCHES, REQUESTS, one_core, round_trip_launches

    # the round trip against its bound again, in fresh launches of every process, the others stopped; then the
    # same launches with every process on one core, the steadier reading beside the target's
    requests = 300 if quick else REQUESTS
    lat["launches"] = round_trip_launches(engine_root, 3 if quick else LAUNCHES, requests)
    lat["launches_one_core"] = round_trip_launches(engine_root, 3 if quick else ONE_CORE_LAUNCHES, requests, one_core())
    batches = batch_workload(quick, engine_root)
    workers = workers_scaling(scene, seconds=seconds) if engine_root is None else []
    from .bench_spanning import spanning_batch

    spanning = spanning_batch(scene, 60 if quick else 300) if engine_root is None else None
    return {"latency": lat, "throughput": rows, "batch_workload": batches, "workers": workers, "spanning": spanning,
            "endpoint": "tcp/127.0.0.1 (loopback), peer mode, multicast scouting off",
            "engine_root": str(engine_root) if engine_root else None}


if __name__ == "__main__":
    if sys.argv[1] == "echo":
        echo_main(int(sys.argv[2]))
    elif sys.argv[1] == "engine-echo":
        engine_echo_main(int(sys.argv[2]))
    elif sys.argv[1] == "handling":
        handling_main(int(sys.argv[2]))
    elif sys.argv[1] == "worker":
        worker_main(sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), float(sys.argv[5]), float(sys.argv[6]), sys.argv[7],
                    sys.argv[8], None if len(sys.argv) < 10 or sys.argv[9] == "-" else int(sys.argv[9], 16))
    elif sys.argv[1] == "workers":
        workers_cli(sys.argv[2:])
    elif sys.argv[1] == "watcher":
        watcher_main(sys.argv[2])
    else:
        raise SystemExit(f"unknown role {sys.argv[1]!r}")
