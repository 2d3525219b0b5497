"""A batch over two workers' landblocks: its two requests in flight together, or one after the other.

`serve --workers 2` on the service benchmark's scene, 50 movers in a landblock of each worker. One client
moves all of them out and back (a batch of 200 moves) with `Client.move_batch`, which sends one request
per landblock and both before it reads either reply, so that the two engines work at the same time;
interleaved with it, the same two requests one after the other (send, wait for the reply, send, wait):
what a client that reads each reply before sending the next request pays. Medians of the round trips.
Run by `python3 -m benchmarks --only service`; alone: `python3 -m benchmarks.bench_spanning`.
"""

from __future__ import annotations

import json
import statistics
import sys
import time
from pathlib import Path
from typing import Any

from .service_harness import Child, bench_walker, free_port, scene_file, start_position
from .common import log

__all__ = ["spanning_batch", "SPANNING_MOVERS"]

#: movers in each of the two workers' landblocks
SPANNING_MOVERS = 50
SPANNING_STEP = 0.2


def spanning_batch(scene: Path, rounds: int) -> dict[str, Any]:
    """Round trips of the batch both ways, `rounds` of each, interleaved; medians in µs."""
    import numpy as np

    from clients import Client
    from service.ownership import Ownership
    from service.scaleout.workers import scene_landblocks

    lbs = [min(p.landblocks or ()) for p in Ownership().split(2, scene_landblocks(str(scene)))]
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    service = Child([sys.executable, "-m", "service", "--scene", str(scene), "--listen", endpoint, "--workers", "2",
                     "--log-level", "WARNING"], "acphys service ready")
    together: list[float] = []
    apart: list[float] = []
    try:
        with Client([endpoint], timeout=30.0) as c:
            c.wait_ready()
            halves = [[c.register(bench_walker(), start_position(k, lb)).id for k in range(SPANNING_MOVERS)] for lb in lbs]
            # each half out and back: the movers end each batch where they began
            batches = [(np.array(h + h, dtype=np.uint64),
                        np.array([[SPANNING_STEP, 0.0, 0.0]] * len(h) + [[-SPANNING_STEP, 0.0, 0.0]] * len(h)))
                       for h in halves]
            ids = np.concatenate([b[0] for b in batches])
            offsets = np.concatenate([b[1] for b in batches])
            for _warm in range(20):
                c.move_batch(ids, offsets=offsets)
            errors = 0
            for _ in range(rounds):
                t0 = time.perf_counter()
                errors += len(c.move_batch(ids, offsets=offsets).errors)
                t1 = time.perf_counter()
                for half_ids, half_offsets in batches:
                    errors += len(c.move_batch(half_ids, offsets=half_offsets).errors)
                t2 = time.perf_counter()
                together.append((t1 - t0) * 1e6)
                apart.append((t2 - t1) * 1e6)
            (health,) = c.health()
            owners = [w["owned"] for w in health["worker_processes"]]
    finally:
        service.stop()
    out: dict[str, Any] = {"landblocks": lbs, "owners": owners, "movers_each": SPANNING_MOVERS, "moves": len(ids),
                           "rounds": rounds, "errors": errors, "together_us": statistics.median(together),
                           "apart_us": statistics.median(apart)}
    out["ratio"] = out["together_us"] / out["apart_us"]
    log(f"service: a batch of {out['moves']} moves over two workers' landblocks: {out['together_us']:.0f} µs with "
        f"both requests in flight, {out['apart_us']:.0f} µs one after the other ({out['ratio']:.2f}x)")
    return out


if __name__ == "__main__":
    print(json.dumps(spanning_batch(scene_file(), int(sys.argv[1]) if len(sys.argv) > 1 else 300), indent=1))
