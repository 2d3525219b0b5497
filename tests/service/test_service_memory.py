"""The service's memory under short-lived bulk clients.

With Zenoh's shared-memory transport on (zenoh's default), every message over
3 KiB that a client process sends goes through a 16 MiB shared-memory pool of
the client's, which the service kept mapped after the client left: about 20
MB of RSS per client session, never given back. The service now switches that
transport off (service/bus/zconfig.py). The clients here use Zenoh's *default*
config (shared memory on), as a client in another language would.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

from service.bus.zconfig import SHM_KEY, make_config
from support.service_harness import ROOT, ServiceProcess, child_env

# One client session: register a mover, send `queries` batch moves of 100 moves each (about 5 KB, over
# zenoh's 3 KiB shared-memory threshold), print how many replies were ok, leave.
_CLIENT = textwrap.dedent("""
    import sys, msgpack, zenoh
    endpoint, queries = sys.argv[1], int(sys.argv[2])
    conf = zenoh.Config()  # zenoh's defaults: shared memory on
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("connect/endpoints", '["%s"]' % endpoint)
    conf.insert_json5("listen/endpoints", "[]")
    conf.insert_json5("scouting/multicast/enabled", "false")
    s = zenoh.open(conf)
    spec = {"spheres": [{"center": [0, 0, 0.48], "radius": 0.48}], "state": ["IsPlayer"]}
    reg = {"v": 1, "mover": spec, "position": {"cell": 0xA9B40001 + 9, "origin": [12.0, 12.0, 80.0]}}
    reply = list(s.get("acphys/lb/A9B4/register", payload=msgpack.packb(reg), timeout=10))[0]
    mid = msgpack.unpackb(reply.ok.payload.to_bytes())["state"]["id"]
    ok = 0
    for q in range(queries):
        moves = [{"id": mid, "offset": [0.01 * ((k % 2) * 2 - 1), 0.0, 0.0], "tag": "padding-%04d" % k}
                 for k in range(100)]
        payload = msgpack.packb({"v": 1, "moves": moves})
        assert len(payload) > 4096, len(payload)
        for r in s.get("acphys/lb/A9B4/move", payload=payload, timeout=10):
            ok += r.ok is not None
    list(s.get("acphys/lb/A9B4/remove", payload=msgpack.packb({"v": 1, "id": mid}), timeout=10))
    s.close()
    print(ok)
""")


def _rss_kib(pid: int) -> int:
    with open(f"/proc/{pid}/status", encoding="ascii") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    raise AssertionError("no VmRSS")


def _client_session(endpoint: str, queries: int) -> int:
    out = subprocess.run([sys.executable, "-c", _CLIENT, endpoint, str(queries)], cwd=ROOT, env=child_env(),
                         capture_output=True, text=True, timeout=60, check=True)
    return int(out.stdout.strip())


def test_the_service_config_switches_zenohs_shared_memory_off() -> None:
    assert make_config().get_json(SHM_KEY) == "false"
    assert make_config(connect=["tcp/127.0.0.1:1"]).get_json(SHM_KEY) == "false"


def test_a_config_file_that_sets_shared_memory_keeps_its_choice(tmp_path) -> None:
    plain = tmp_path / "plain.json5"
    plain.write_text('{ mode: "peer" }')
    assert make_config(config_file=str(plain)).get_json(SHM_KEY) == "false"
    chosen = tmp_path / "shm.json5"
    chosen.write_text('{ mode: "peer", transport: { shared_memory: { enabled: true } } }')
    assert make_config(config_file=str(chosen)).get_json(SHM_KEY) == "true"


def test_reconnecting_bulk_clients_do_not_grow_the_service() -> None:
    with ServiceProcess() as svc:
        assert svc.proc is not None
        assert _client_session(svc.endpoint, 8) == 8  # warm-up: first allocations, caches, landblock
        before = _rss_kib(svc.proc.pid)
        for _ in range(5):
            assert _client_session(svc.endpoint, 8) == 8
        grown = _rss_kib(svc.proc.pid) - before
    # with the shared-memory pools kept mapped this grew by about 5 x 20 MB; 16 MiB leaves room for
    # allocator noise while still failing on a single retained pool
    assert grown < 16 * 1024, f"service RSS grew by {grown} KiB over 5 client sessions"
