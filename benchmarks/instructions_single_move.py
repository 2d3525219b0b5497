"""Instructions per handled single move (`{"v": 1, "move": ...}` on `P/lb/XXYY/move`), counted by callgrind.

A one-move round trip is mostly Zenoh and the engine; what the service adds is its query callback:
the request decoded and checked, the engine lock and queue checks, the move applied and counted, the
State packed and replied. Timed, that part swings with the machine's load and with how cold the caches
are; counted, it is the same every run. A child process builds the service node on the service
benchmark's flat scene (its bus a stand-in nobody subscribes to, so no Zenoh session runs: Zenoh's own
receive, reply and matching status are not counted), registers one mover, and calls the callback of
the queryable on `P/lb/*/*` (`ServiceNode.lb_queryable`, which hands a move to its handler) with
stand-in queries, as `bench_service.handling_main` does.
Two runs that differ only in the number of moves give the instructions per move as their difference,
start-up and loading cancelled out. Run once with the engine replaced by benchmarks/standins.py's
`NoEngine` (every move resolves to the mover's current state) and once with the real engine: the first
is the service's own work, the difference between them the engine's share. PYTHONHASHSEED is fixed, OpenBLAS kept
to one thread and the once-a-second snapshot reading left out, so the count is the same every run.

    python3 -m benchmarks.instructions_single_move [ROOT]
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

__all__ = ["count_single_move", "per_move", "MOVES"]

#: handled moves of the short and the long run; their difference is what is counted
MOVES = (200, 1200)

# The measured checkout's service and engine are imported first, then this checkout's harness.
_CHILD = """
import json, sys
root, bench_root, moves, engine = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
sys.path.insert(0, root)
import msgpack
from service import heap
from service.bus.node import NodeOptions, ServiceNode
from service.core import ServiceCore
from service.protocol.codec import encode_mover_spec, encode_position
from service.protocol.requests import parse_register
from service.world_source import open_world
sys.path.insert(0, bench_root)
from benchmarks.service_harness import bench_walker, scene_file, start_position
from benchmarks.standins import NoEngine, SilentBus, StandInQuery

world = open_world(scene=str(scene_file()))
node = ServiceNode(world, None, NodeOptions())
# the node's core on a bus nobody subscribes to: no Zenoh session (its threads would count too)
node.core = core = ServiceCore(world, SilentBus(), ownership=node.options.ownership, instance="count",
                               stats=node.stats)
start = start_position(0)
mid = core.register(parse_register({"v": 1, "mover": encode_mover_spec(bench_walker()),
                                    "position": encode_position(start)}))["state"]["id"]
if engine == "none":
    core.world = NoEngine(world, core.movers[mid].last)
# the snapshots health and stats answer from are read again once a wall-clock second, however many moves
# that is: under callgrind's slowdown that would count the machine's speed, so it is left out
core._cache_read_at = float("inf")
key = node.keys.move(start.landblock)
handler = node.lb_queryable("*")
payloads = [msgpack.packb({"v": 1, "move": {"id": mid, "offset": [d, 0.0, 0.0]}}) for d in (0.2, -0.2)]
heap.tune()
heap.settle()  # as a serving process does after loading its world
queries = [StandInQuery(key, payload) for payload in payloads]  # made once: their making is not counted
for i in range(moves):
    handler(queries[i % 2])
print("RESULT " + json.dumps({"replies": sum(q.replies for q in queries)}))
"""


def per_move(low: int, high: int, moves: tuple[int, int] = MOVES) -> float:
    """Instructions per move from the counts of a short (`low`) and a long (`high`) run."""
    return per_unit(low, high, moves)


def _run(python: str, root: Path, moves: int, engine: str) -> int:
    result, counted = run_counted(python, root, _CHILD, [str(common.ROOT), str(moves), engine], [],
                                  {"OPENBLAS_NUM_THREADS": "1"})  # its idle workers spin under valgrind
    if result["replies"] != moves:
        raise RuntimeError(f"{result['replies']} of {moves} moves were answered")
    return counted


def count_single_move(python: str, root: Path | None = None) -> dict[str, Any]:
    """The service's instructions per handled single move with `root`'s service and engine (default: this
    checkout's): with the engine replaced (`service_per_move`) and with it (`per_move`), and the engine's
    share as their difference."""
    root = root or common.ROOT
    jobs = [(moves, engine) for engine in ("none", "real") for moves in MOVES]
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        totals = dict(zip(jobs, pool.map(lambda job: _run(python, root, *job), jobs)))
    service = per_move(totals[(MOVES[0], "none")], totals[(MOVES[1], "none")])
    whole = per_move(totals[(MOVES[0], "real")], totals[(MOVES[1], "real")])
    return {"per_move": whole, "service_per_move": service, "engine_per_move": whole - service,
            "moves": list(MOVES)}


def main(argv: list[str]) -> None:
    root = Path(argv[0]).resolve() if argv else common.ROOT
    out = count_single_move(python_of(root), root)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main(sys.argv[1:])
