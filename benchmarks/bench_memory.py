"""Memory soak: the service's RSS under reconnecting bulk clients.

A service on the flat benchmark scene is fed batched moves by short-lived
client sessions, two at a time, until a million moves have been resolved
and at least three minutes have passed (or a time budget runs out): the
target is flat RSS after the first minute. Each client session is its own process with
Zenoh's *default* configuration (shared memory on), as a client written in
another language would be: it registers 20 movers, sends batches of 100
moves (about 5 KB each, over Zenoh's 3 KiB shared-memory threshold), removes
its movers and leaves. The service's RSS is read from /proc once a second.

Two runs: the service as shipped (its Zenoh shared-memory transport off,
service/bus/zconfig.py) and, shorter, the same service given a config file that
switches the shared-memory transport on, which is how it ran before: it
kept every departed client's 16 MiB pool mapped.

Bounded: loopback only, fixed counts, a time budget per run.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

from . import common
from .service_harness import Child, child_env, free_port, scene_file
from .common import log

MOVERS_PER_SESSION = 20
BATCH = 100


def client_main(endpoint: str, index: int, batches: int) -> None:
    """One client session (zenoh defaults, shared memory on): register, move in batches, remove; print
    the number of moves answered ok."""
    import msgpack
    import zenoh

    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", json.dumps([endpoint]))
    conf.insert_json5("listen/endpoints", "[]")
    conf.insert_json5("scouting/multicast/enabled", "false")
    session = zenoh.open(conf)
    spec = {"spheres": [{"center": [0, 0, 0.48], "radius": 0.48}, {"center": [0, 0, 1.35], "radius": 0.48}],
            "state": ["Contact", "OnWalkable", "IsPlayer", "EdgeSlide"]}
    ids = []
    for k in range(MOVERS_PER_SESSION):
        pos = _start(index * MOVERS_PER_SESSION + k)
        reply = list(session.get(f"acphys/lb/{pos['cell'] >> 16:04X}/register",
                                 payload=msgpack.packb({"v": 1, "mover": spec, "position": pos}), timeout=30))[0]
        assert reply.ok is not None, "register refused"
        ids.append(msgpack.unpackb(reply.ok.payload.to_bytes())["state"]["id"])
    key = f"acphys/lb/{_start(0)['cell'] >> 16:04X}/move"
    ok = 0
    for b in range(batches):
        sign = 1.0 if b % 2 else -1.0
        moves = [{"id": ids[k % MOVERS_PER_SESSION], "offset": [0.2 * sign, 0.0, 0.0], "tag": k} for k in range(BATCH)]
        for r in session.get(key, payload=msgpack.packb({"v": 1, "moves": moves}), timeout=30):
            if r.ok is not None:
                ok += sum(1 for e in msgpack.unpackb(r.ok.payload.to_bytes())["results"] if "error" not in e)
    for mid in ids:
        list(session.get(key.replace("/move", "/remove"), payload=msgpack.packb({"v": 1, "id": mid}), timeout=30))
    session.close()
    print(f"RESULT {ok}", flush=True)


def _start(n: int) -> dict[str, Any]:
    """A start position on the flat scene's landblock, one mover every 6 m (wrapping)."""
    from .scenes import LB, cell_at

    x, y = 12.0 + 6.0 * (n % 28), 12.0 + 6.0 * ((n // 28) % 28)
    return {"cell": cell_at(LB, x, y), "origin": [x, y, 50.0]}


def _rss_kib(pid: int) -> int:
    with open(f"/proc/{pid}/status", encoding="ascii") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def soak(moves: int, seconds: float, shared_memory: bool, batches_per_session: int = 100,
         min_seconds: float = 0.0) -> dict[str, Any]:
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    args = [sys.executable, "-m", "service", "--scene", str(scene_file()), "--log-level", "WARNING"]
    config: Path | None = None
    if shared_memory:
        config = common.OUT / f"soak-shm-{port}.json5"
        config.write_text(json.dumps({"mode": "peer", "listen": {"endpoints": [endpoint]},
                                      "scouting": {"multicast": {"enabled": False}},
                                      "transport": {"shared_memory": {"enabled": True}}}))
        args += ["--zenoh-config", str(config)]
    else:
        args += ["--listen", endpoint]
    service = Child(args, "acphys service ready")
    samples: list[tuple[float, int]] = []
    stop = threading.Event()
    t0 = time.monotonic()

    def sample() -> None:
        while not stop.wait(1.0):
            samples.append((time.monotonic() - t0, _rss_kib(service.proc.pid)))

    start_rss = _rss_kib(service.proc.pid)
    threading.Thread(target=sample, daemon=True).start()
    done = sessions = failures = 0
    deadline = t0 + seconds
    try:
        while (done < moves or time.monotonic() - t0 < min_seconds) and time.monotonic() < deadline:
            procs = [subprocess.Popen([sys.executable, "-m", "benchmarks.bench_memory", "client", endpoint,
                                       str(sessions + i), str(batches_per_session)],
                                      cwd=common.ROOT, env=child_env(), stdout=subprocess.PIPE,
                                      stderr=subprocess.PIPE, text=True) for i in range(2)]
            for p in procs:
                out, _err = p.communicate(timeout=300)
                got = [ln for ln in out.splitlines() if ln.startswith("RESULT ")]
                if p.returncode != 0 or not got:
                    failures += 1
                else:
                    done += int(got[-1].split()[1])
                sessions += 1
    finally:
        stop.set()
        end_rss = _rss_kib(service.proc.pid)
        elapsed = time.monotonic() - t0
        service.stop()
        if config is not None:
            config.unlink(missing_ok=True)
    at_minute = next((kib for t, kib in samples if t >= 60.0), None)
    row = {"shared_memory": shared_memory, "moves": done, "sessions": sessions, "failed_sessions": failures,
           "seconds": elapsed, "rss_start_mib": start_rss / 1024, "rss_after_first_minute_mib":
           None if at_minute is None else at_minute / 1024, "rss_end_mib": end_rss / 1024,
           "rss_max_mib": max([end_rss] + [k for _, k in samples]) / 1024,
           "growth_after_first_minute_pct": None if not at_minute else (end_rss - at_minute) / at_minute * 100.0,
           "growth_per_session_mib": (end_rss - start_rss) / 1024 / max(1, sessions),
           "timeline": [(round(t, 1), round(k / 1024, 1)) for t, k in samples[:: max(1, len(samples) // 60)]]}
    log(f"memory soak (shared memory {'on' if shared_memory else 'off'}): {done:,} moves in {sessions} sessions, "
        f"{elapsed:.0f} s; RSS {row['rss_start_mib']:.0f} MiB at start, "
        f"{row['rss_after_first_minute_mib'] or float('nan'):.0f} after a minute, {row['rss_end_mib']:.0f} at the end")
    return row


def run(quick: bool) -> dict[str, Any]:
    moves = 100_000 if quick else 1_000_000
    rows = [soak(moves, 180.0 if quick else 900.0, shared_memory=False, min_seconds=60.0 if quick else 180.0),
            soak(moves // 5, 120.0 if quick else 300.0, shared_memory=True)]
    return {"rows": rows, "movers_per_session": MOVERS_PER_SESSION, "batch": BATCH}


if __name__ == "__main__":
    if len(sys.argv) >= 2 and sys.argv[1] == "client":
        client_main(sys.argv[2], int(sys.argv[3]), int(sys.argv[4]))
    else:
        print(json.dumps(run("--quick" in sys.argv), indent=1))
        os._exit(0)
