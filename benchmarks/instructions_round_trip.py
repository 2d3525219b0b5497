"""Instructions per one-move round trip, the whole stack in one process, counted by callgrind.

The timed round trip (section 3) swings by ±20 µs between series of one run on this machine, more than
most changes to the service or the client library. Counted, it is steady: one process holds both ends,
two Zenoh sessions over loopback TCP, and callgrind counts every thread of it (Zenoh's runtimes on both
sides, the server's callback, the client's call); only the kernel's side (the socket's copies, the
thread wake-ups) is left out. Four series, each the difference of a 200 and a 1,200 round-trip run
after 50 unmeasured ones:

- `bound`: the engine alone behind a bare queryable on a literal key (msgpack in, `World.move`, msgpack
  out, nothing checked), asked with a plain `get` on the key's text: the timed bound's own server and
  client (bench_service.engine_echo_handler);
- `bound_declared`: the same, the key declared on the asking session first, as the client library
  declares its keys (clients/client.py, `Client._lb_key`);
- `service_raw`: a service node as `python -m service` starts one, asked the same request bytes by a plain
  `get` on its `P/lb/XXYY/move` key, declared as in `bound_declared`, the reply read by msgpack;
- `client`: the same node asked by the client library's `Client.move`: the timed `move`;
- `floor_raw`: the same node with the protocol's floor declared on its session (benchmarks/service_floor.py's
  lean handler on a literal key: the request read by the service's reader, `World.move`, the State packed
  by the service's packer, the reply; nothing else), asked the raw request as in `service_raw`;
- `floor`: that handler asked by the floor's least client (`floor_client_move`): one move as the protocol
  alone makes a service and a client do it, the timed launches' `floor_move`.

`service_raw - bound_declared` is what the service adds (its checks, stats, record, State, and the dispatch
of its wildcard queryable), `client - service_raw` what the client library adds, and `client - bound` the
two together against the timed bound. `floor - bound` is what the protocol itself costs over the bound, so
`client - floor` is the service's and the client library's own work beyond it (`floor_raw` splits the floor
between its server and its client, as `service_raw` splits the target's series). Zenoh's timers tick in
wall time, which callgrind slows some fifty times, so a count moves between runs: `client` counted 287,069 and 307,244 in two runs of one tree on this
project's 2-core machine, where two counted runs share it.

    python3 -m benchmarks.instructions_round_trip [ROOT]
"""

from __future__ import annotations

import json
import os
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from . import common
from .callgrind import per_unit, python_of, run_counted

__all__ = ["count_round_trip", "ROUND_TRIPS", "SERIES"]

#: round trips of the short and the long run; their difference is what is counted
ROUND_TRIPS = (200, 1200)
SERIES = ("bound", "bound_declared", "service_raw", "client", "floor_raw", "floor")

# The measured checkout's service, client library and engine are imported first, then this checkout's
# scene and walker. Both sessions listen and connect on 127.0.0.1 only; every loop is bounded.
_CHILD = """
import json, socket, sys, time
root, bench_root, series, trips = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
sys.path.insert(0, root)
import msgpack
import zenoh
from clients import Client, Move
from service.bus.zconfig import make_config
from service.world_source import open_world
sys.path.insert(0, bench_root)
from benchmarks.bench_service import ENGINE_ECHO_KEY, engine_echo_handler
from benchmarks.service_harness import bench_walker, scene_file, start_position

with socket.socket() as s:
    s.bind(("127.0.0.1", 0))
    endpoint = f"tcp/127.0.0.1:{s.getsockname()[1]}"
world = open_world(scene=str(scene_file()))
start = start_position(0)

def request(mover_id, i):
    return msgpack.packb({"v": 1, "move": Move(mover_id, offset=(0.2 if i % 2 == 0 else -0.2, 0.0, 0.0)).to_wire()},
                         use_bin_type=True)

if series.startswith("bound"):
    engine_id = world.add_mover(bench_walker(), start, None, None)
    server = zenoh.open(make_config(listen=[endpoint]))
    queryable = server.declare_queryable(ENGINE_ECHO_KEY, engine_echo_handler(world, engine_id))
    session = zenoh.open(make_config(connect=[endpoint]))
    key = ENGINE_ECHO_KEY
    if series == "bound_declared":
        key = session.declare_keyexpr(key)
    payloads = [request(1, i) for i in range(2)]

    def one(i):
        replies = list(session.get(key, payload=payloads[i % 2], timeout=60.0))
        return msgpack.unpackb(replies[0].ok.payload.to_bytes())
else:
    from service.bus.node import NodeOptions, ServiceNode
    node = ServiceNode(world, make_config(listen=[endpoint]), NodeOptions(queue_capacity=4096, tune_heap=True))
    node.start()
    client = Client([endpoint], timeout=60.0)
    for _ in range(200):  # the client's session meets the node's queryables some 0.1 s after it opens
        try:
            mid = client.register(bench_walker(), start).id
            break
        except Exception:
            time.sleep(0.05)
    if series.startswith("floor"):  # the protocol's floor beside the node's own queryables, on its session
        from benchmarks.service_floor import FLOOR_EXACT_KEY, floor_client_move, lean_move_handler
        floor = node.session.declare_queryable(FLOOR_EXACT_KEY, lean_move_handler(node.core))
    if series == "client":
        offsets = [(0.2, 0.0, 0.0), (-0.2, 0.0, 0.0)]

        def one(i):
            return client.move(mid, offset=offsets[i % 2])
    elif series == "floor":
        one = floor_client_move(client.session, FLOOR_EXACT_KEY, mid)
    else:
        key = client.session.declare_keyexpr(FLOOR_EXACT_KEY if series == "floor_raw"
                                             else client.keys.move(start.landblock))
        payloads = [request(mid, i) for i in range(2)]

        def one(i):
            replies = list(client.session.get(key, payload=payloads[i % 2], timeout=60.0))
            return msgpack.unpackb(replies[0].ok.payload.to_bytes(), strict_map_key=False)
for _ in range(200):  # the bound's session, too, meets its queryable after it opens
    try:
        one(0)
        break
    except Exception:
        time.sleep(0.05)
for i in range(50):
    one(i)
answered = 0
for i in range(trips):
    answered += one(i) is not None
print("RESULT " + json.dumps({"answered": answered}), flush=True)
import os
os._exit(0)  # the sessions' threads are not waited for: their closing would be counted too
"""


def _run(python: str, root: Path, series: str, trips: int) -> int:
    result, counted = run_counted(python, root, _CHILD, [str(common.ROOT), series, str(trips)], [],
                                  {"OPENBLAS_NUM_THREADS": "1"})  # its idle workers spin under valgrind
    if result["answered"] != trips:
        raise RuntimeError(f"{series}: {result['answered']} of {trips} round trips were answered")
    return counted


def count_round_trip(python: str, root: Path | None = None) -> dict[str, Any]:
    """Instructions per one-move round trip of each series with `root`'s service, client library and engine
    (default: this checkout's), and the differences between them."""
    root = root or common.ROOT
    jobs = [(series, trips) for series in SERIES for trips in ROUND_TRIPS]
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        totals = dict(zip(jobs, pool.map(lambda job: _run(python, root, *job), jobs)))
    out: dict[str, Any] = {s: per_unit(totals[(s, ROUND_TRIPS[0])], totals[(s, ROUND_TRIPS[1])], ROUND_TRIPS)
                           for s in SERIES}
    out["service_over_bound"] = out["service_raw"] - out["bound_declared"]
    out["client_over_service_raw"] = out["client"] - out["service_raw"]
    out["client_over_bound"] = out["client"] - out["bound"]
    out["floor_over_bound"] = out["floor"] - out["bound"]
    out["floor_service_over_bound"] = out["floor_raw"] - out["bound_declared"]
    out["floor_client_over_raw"] = out["floor"] - out["floor_raw"]
    out["client_over_floor"] = out["client"] - out["floor"]
    out["round_trips"] = list(ROUND_TRIPS)
    return out


def main(argv: list[str]) -> None:
    root = Path(argv[0]).resolve() if argv else common.ROOT
    print(json.dumps(count_round_trip(python_of(root), root), indent=1))


if __name__ == "__main__":
    main(sys.argv[1:])
