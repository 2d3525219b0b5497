"""Instructions per `Client.move` in the client library, counted by callgrind.

One move's round trip is Zenoh, the service and the engine, and the client library's own part: the
Move built and packed, the key looked up, the reply read into a MoverState. Timed, that part swings
with the machine's load and with how cold the caches are (code run after an idle spell runs several
times slower, roughly in proportion to the instructions it executes); counted, it is the same every
run. A child process builds a `Client` on benchmarks/standins.py's `StandInSession` (no Zenoh session
runs: its own send and receive are not counted), which answers every request with one State as the
service packs it (as `bench_service._client_part` does), and calls `client.move(7, offset=(±0.2, 0, 0))`.
Two runs that differ only in the number of calls give the instructions per call as their difference,
start-up and imports cancelled out. PYTHONHASHSEED is fixed, so the count is the same every run.

    python3 -m benchmarks.instructions_client_move [ROOT]
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

__all__ = ["count_client_move", "per_call", "CALLS"]

#: `Client.move` calls of the short and the long run; their difference is what is counted
CALLS = (200, 1200)

# The measured checkout's client library, service protocol and engine are imported first, then this
# checkout's stand-ins.
_CHILD = """
import json, sys
root, bench_root, calls = sys.argv[1], sys.argv[2], int(sys.argv[3])
sys.path.insert(0, root)
from clients import Client
from engine import MoveResult
from engine.geometry import Position, Vec3
from service.protocol.codec import pack_state
from service.protocol.frames import state_message
sys.path.insert(0, bench_root)
from benchmarks.service_harness import start_position
from benchmarks.standins import StandInSession

start = start_position(0)
result = MoveResult(True, Position.at(start.cell_id, Vec3(20.0, 20.0, 50.0)), "OK", True, True, None,
                    start.cell_id, None, None, False, 0, ["Contact", "OnWalkable"], [])
client = Client(session=StandInSession(state_message(pack_state(7, 1, result, []))))
client.locate(7, start.landblock)
offsets = [(0.2, 0.0, 0.0), (-0.2, 0.0, 0.0)]  # made once: their making is not counted
answered = 0
for i in range(calls):
    answered += client.move(7, offset=offsets[i % 2]).id == 7
print("RESULT " + json.dumps({"answered": answered}))
"""


def per_call(low: int, high: int, calls: tuple[int, int] = CALLS) -> float:
    """Instructions per call from the counts of a short (`low`) and a long (`high`) run."""
    return per_unit(low, high, calls)


def _run(python: str, root: Path, calls: int) -> int:
    result, counted = run_counted(python, root, _CHILD, [str(common.ROOT), str(calls)], [],
                                  {"OPENBLAS_NUM_THREADS": "1"})  # its idle workers spin under valgrind
    if result["answered"] != calls:
        raise RuntimeError(f"{result['answered']} of {calls} moves were answered with the mover's State")
    return counted


def count_client_move(python: str, root: Path | None = None) -> dict[str, Any]:
    """The client library's instructions per `Client.move` with `root`'s client library (default: this
    checkout's)."""
    root = root or common.ROOT
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        low, high = pool.map(lambda calls: _run(python, root, calls), CALLS)
    return {"per_call": per_call(low, high), "calls": list(CALLS)}


def main(argv: list[str]) -> None:
    root = Path(argv[0]).resolve() if argv else common.ROOT
    out = count_client_move(python_of(root), root)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main(sys.argv[1:])
