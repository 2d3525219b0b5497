"""Instructions per move of the service's column path on the batch workload, counted by callgrind.

The batch workload is benchmarks/bench_batches.py's. The service's own work per request is what keeps its
column form below the engine's rate (docs/performance.md, "What limits each figure"), and on this VM its
timings swing by tens of per cent from one minute to the next. This counts it instead: a child process
builds the service core on the demo world with a stand-in bus, registers the batch workload's 100 movers,
and handles the two client processes' column requests (decode, checks, run_columns, reply_message:
everything the query callback does but Zenoh's receive and reply) round after round under callgrind. Two
runs that differ only in the number of rounds give the instructions per move as their difference, start-up
and loading cancelled out; the same two runs with collection switched on only inside `run_batch` give the
engine's share. PYTHONHASHSEED is fixed and OpenBLAS kept to one thread (its idle workers spin under
valgrind), so the count is the same every run.
Part of `python3 -m benchmarks --only instructions` (benchmarks/bench_instructions.py).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from . import common
from .callgrind import per_unit, run_counted

__all__ = ["count_column_path", "per_move", "ROUNDS", "MOVES_PER_ROUND"]

#: rounds of the short and the long run; their difference is what is counted
ROUNDS = (4, 14)
#: each round is both client processes' requests: 2 x 100 moves
MOVES_PER_ROUND = 200
RUN_BATCH_SYMBOL = "CPyPy_batch___run_batch"

# The measured checkout's engine and service are imported first, then this checkout's harness (which uses
# the service modules already loaded, whichever checkout they came from).
_CHILD = """
import json, sys, time
root, bench_root, rounds = sys.argv[1], sys.argv[2], int(sys.argv[3])
sys.path.insert(0, root)
from engine import load_scene
from service import heap
from service.column_moves import reply_message, run_columns
from service.protocol.column_request import parse_column_request
from service.core import ServiceCore
from service.ownership import Ownership
from service.protocol.requests import RegisterRequest, decode_envelope
from service.stats import ServiceStats
sys.path.insert(0, bench_root)
from benchmarks.bench_batches import _column_request_bytes, batch_spots, demo_scene
from benchmarks.scenes import PLAYER

class Bus:  # nobody subscribes: nothing is published, as in the batch workload
    def states_watched(self): return False
    def batch_watched(self): return False
    def columns_watched(self): return False
    def publish_state(self, *args): pass

world = load_scene(str(demo_scene()))
core = ServiceCore(world, Bus(), ownership=Ownership(), instance="count", stats=ServiceStats())
ids = [core.register(RegisterRequest(None, PLAYER, pos, plane, cell))["state"]["id"]
       for pos, plane, cell in batch_spots(world)]
half = len(ids) // 2
requests = [_column_request_bytes(ids[:half]), _column_request_bytes(ids[half:])]
heap.tune()
heap.settle()  # as a serving process does after loading its world
served = 0
for _ in range(rounds):
    for payload in requests:
        out, _ = run_columns(core, parse_column_request(decode_envelope(payload)), time.monotonic())
        reply_message(out)
        served += out.n - len(out.errors)
print("RESULT " + json.dumps({"moves": served}))
"""


def per_move(low: int, high: int, rounds: tuple[int, int] = ROUNDS, moves_per_round: int = MOVES_PER_ROUND) -> float:
    """Instructions per move from the counts of a short (`low`) and a long (`high`) run."""
    return per_unit(low, high, (rounds[0] * moves_per_round, rounds[1] * moves_per_round))


def _run(python: str, root: Path, rounds: int, engine_only: bool) -> int:
    toggle = ["--collect-atstart=no", f"--toggle-collect={RUN_BATCH_SYMBOL}"] if engine_only else []
    result, counted = run_counted(python, root, _CHILD, [str(common.ROOT), str(rounds)], toggle,
                                  {"OPENBLAS_NUM_THREADS": "1"})
    if result["moves"] != rounds * MOVES_PER_ROUND:
        raise RuntimeError(f"the column path resolved {result['moves']} of {rounds * MOVES_PER_ROUND} moves")
    return counted


def count_column_path(python: str, root: Path | None = None) -> dict[str, Any]:
    """The column path's instructions per move with `root`'s service and engine (default: this checkout's),
    and run_batch's share of them."""
    root = root or common.ROOT
    jobs = [(rounds, engine_only) for engine_only in (False, True) for rounds in ROUNDS]
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        totals = dict(zip(jobs, pool.map(lambda job: _run(python, root, *job), jobs)))
    whole = per_move(totals[(ROUNDS[0], False)], totals[(ROUNDS[1], False)])
    engine = per_move(totals[(ROUNDS[0], True)], totals[(ROUNDS[1], True)])
    return {"per_move": whole, "run_batch_per_move": engine, "rest_per_move": whole - engine,
            "rounds": list(ROUNDS), "moves_per_round": MOVES_PER_ROUND}
