"""Across machines, on Zenoh's own routing: each party in its own network namespace.

The test builds its own network: a hub namespace with a bridge, and four
namespaces wired to it by veth pairs, with addresses in 10.213.7.0/24 that
exist only inside them. `acphys router` runs in one (10.213.7.1), a service
instance in each of two more (the demo world split west A9B4,A9B5 / east
AAB4,AAB5, both in client mode connected to the router over mutual TLS,
with certificates of a CA the test makes: a cluster, service/security/cluster.py),
and a client, with no credentials, over plain tcp in the fourth, which walks a mover across the split and back. Every request
must be answered exactly once and every state arrive, in seq order, on the
client's `P/obj/*/state` subscription. The commands are those of
docs/protocol.md, "Across machines" (`acphys` run as `python3 -m clients`).

Names are unique per run; every namespace and process is removed at the end,
also on failure. Skipped, with the reason, where namespaces cannot be made.
"""

from __future__ import annotations

import json
import os
import secrets
import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from dataclasses import dataclass, field
from typing import Any

import pytest

from support.cluster_files import cluster_file, make_certificates
from support.service_harness import DEMO_SCENE, ROOT, TESTS, child_env

SUBNET = "10.213.7"
ROUTER_ADDR = f"{SUBNET}.1"
ROUTER_ENDPOINT = f"tcp/{ROUTER_ADDR}:7447"
ROUTER_TLS = f"tls/{ROUTER_ADDR}:7450"
#: (role, host number in the /24)
ROLES = (("router", 1), ("east", 2), ("west", 3), ("client", 4))
START_TIMEOUT = 60.0


def _ip(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(["ip", *args], capture_output=True, text=True, timeout=30)


def _check(r: subprocess.CompletedProcess[str]) -> None:
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(r.args)}: {r.stderr.strip()}")


@dataclass
class Network:
    """The namespaces of one run; `close()` deletes every one it made."""

    tag: str = field(default_factory=lambda: secrets.token_hex(3))
    made: list[str] = field(default_factory=list)

    def ns(self, role: str) -> str:
        return f"acphys-{self.tag}-{role}"

    def add_ns(self, role: str) -> str:
        name = self.ns(role)
        _check(_ip("netns", "add", name))
        self.made.append(name)
        _check(_ip("-n", name, "link", "set", "lo", "up"))
        return name

    def build(self) -> None:
        hub = self.add_ns("hub")
        _check(_ip("-n", hub, "link", "add", "br0", "type", "bridge"))
        _check(_ip("-n", hub, "link", "set", "br0", "up"))
        for role, host in ROLES:
            ns = self.add_ns(role)
            inner, outer = f"v{self.tag}{host}", f"h{self.tag}{host}"  # interface names of at most 15 chars
            _check(_ip("-n", ns, "link", "add", inner, "type", "veth", "peer", "name", outer, "netns", hub))
            _check(_ip("-n", hub, "link", "set", outer, "master", "br0", "up"))
            _check(_ip("-n", ns, "addr", "add", f"{SUBNET}.{host}/24", "dev", inner))
            _check(_ip("-n", ns, "link", "set", inner, "up"))

    def close(self) -> None:
        for name in reversed(self.made):
            _ip("netns", "del", name)
        self.made.clear()


class NsProcess:
    """A command run with `ip netns exec NS`; a context manager that always stops it."""

    def __init__(self, ns: str, args: list[str], marker: str | None = None) -> None:
        self.args = ["ip", "netns", "exec", ns, *args]
        self.marker = marker
        self.output: list[str] = []
        self.proc: subprocess.Popen[str] | None = None

    def __enter__(self) -> NsProcess:
        self.proc = subprocess.Popen(self.args, cwd=ROOT, env=child_env(), stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True)
        ready = threading.Event()

        def pump() -> None:
            assert self.proc is not None and self.proc.stdout is not None
            for line in self.proc.stdout:
                self.output.append(line)
                if self.marker is not None and self.marker in line:
                    ready.set()

        threading.Thread(target=pump, daemon=True).start()
        if self.marker is not None:
            deadline = time.monotonic() + START_TIMEOUT
            while not ready.wait(0.05):
                if self.proc.poll() is not None or time.monotonic() > deadline:
                    self.stop()
                    raise RuntimeError(f"{self.args} did not start:\n" + "".join(self.output))
        return self

    def stop(self, timeout: float = 15.0) -> int | None:
        if self.proc is None:
            return None
        if self.proc.poll() is None:
            self.proc.send_signal(2)  # SIGINT: a clean stop
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(10)
        return self.proc.returncode

    def __exit__(self, *_: object) -> None:
        self.stop()


def _skip_reason() -> str | None:
    if not sys.platform.startswith("linux"):
        return "network namespaces need Linux"
    if shutil.which("ip") is None:
        return "the `ip` command (iproute2) is not installed"
    if os.geteuid() != 0:
        return "creating network namespaces needs root"
    return None


@pytest.fixture()
def network() -> Iterator[Network]:
    reason = _skip_reason()
    if reason:
        pytest.skip(reason)
    net = Network()
    try:
        try:
            net.add_ns("probe")
        except RuntimeError as e:
            pytest.skip(f"cannot create a network namespace here: {e}")
        try:
            net.build()
        except RuntimeError as e:  # e.g. a kernel without veth or bridge support
            pytest.skip(f"cannot build the test network here: {e}")
        yield net
    finally:
        net.close()
    leftover = _ip("netns", "list").stdout
    assert net.tag not in leftover, leftover


def acphys(*args: str) -> list[str]:
    return [sys.executable, "-m", "clients", *args]


def service(own: str, member: Path) -> list[str]:
    return [sys.executable, "-m", "service", "--scene", str(DEMO_SCENE), "--own", own, "--mode", "client",
            "--cluster", str(member), "--log-level", "WARNING"]


def test_instances_in_two_namespaces_behind_a_router(network: Network, tmp_path: Path) -> None:
    make_certificates(tmp_path)  # ca.pem and one instance certificate, shared by the router and the instances
    router = cluster_file(tmp_path, "router", [ROUTER_TLS], [])
    member = cluster_file(tmp_path, "member", [], [ROUTER_TLS])
    with NsProcess(network.ns("router"), acphys("router", "--listen", ROUTER_ENDPOINT, "--cluster", str(router)),
                   "acphys router ready"), \
         NsProcess(network.ns("west"), service("A9B4,A9B5", member), "acphys service ready") as west, \
         NsProcess(network.ns("east"), service("AAB4,AAB5", member), "acphys service ready") as east:
        # the client runs this file's client_main, found beside it, with tests/ for its `support` imports
        code = (f"import json, sys; sys.path[:0] = [{str(Path(__file__).parent)!r}, {str(TESTS)!r}]; "
                "from test_service_netns import client_main; "
                f"print('RESULT ' + json.dumps(client_main({ROUTER_ENDPOINT!r})))")
        r = subprocess.run(["ip", "netns", "exec", network.ns("client"), sys.executable, "-c", code], cwd=ROOT,
                           env=child_env(), capture_output=True, text=True, timeout=180)
        lines = [ln for ln in r.stdout.splitlines() if ln.startswith("RESULT ")]
        assert r.returncode == 0 and lines, r.stdout[-3000:] + r.stderr[-3000:]
        res = json.loads(lines[-1][7:])
        # the command line from the client's machine, as docs/protocol.md shows it
        stats = subprocess.run(["ip", "netns", "exec", network.ns("client"),
                                *acphys("stats", "--connect", ROUTER_ENDPOINT, "--json")],
                               cwd=ROOT, env=child_env(), capture_output=True, text=True, timeout=60)
        assert stats.returncode == 0, stats.stderr
        assert sorted(s["instance"] for s in json.loads(stats.stdout)) == \
            sorted(ln.split("instance ")[1].split(",")[0] for p in (west, east) for ln in p.output if "ready" in ln)
        move = subprocess.run(["ip", "netns", "exec", network.ns("client"),
                               *acphys("move", "--connect", ROUTER_ENDPOINT, "--start", "A9B40001", "20", "20", "60",
                                       "--offset", "1", "0", "0", "--json")],
                              cwd=ROOT, env=child_env(), capture_output=True, text=True, timeout=60)
        assert move.returncode == 0, move.stderr
        moved = json.loads(move.stdout)
        assert moved["seq"] == 1 and moved["landblock"] == 0xA9B4
        assert west.stop() == 0 and east.stop() == 0
    assert res["instances"] == 2
    assert res["replies"] == [1] * len(res["replies"]) and len(res["replies"]) == 50  # each answered exactly once
    assert res["errors"] == []
    base = res["base_seq"]
    assert res["seqs"] == list(range(base + 1, base + 51))  # every reply, the next seq
    assert res["published"] == list(range(base + 1, base + 51))  # every state published, in seq order
    lbs = res["landblocks"]
    assert lbs[0] == 0xA9B4 and 0xAAB4 in lbs and lbs[-1] == 0xA9B4  # it crossed to the east instance and back
    assert res["handovers_in"] == 2
    assert res["forged_replies"] == 0 and res["handovers_in_after_forgery"] == 2


def client_main(router: str) -> dict[str, Any]:
    """In the client namespace: register a mover in the west, walk it 25 m east and back with raw
    queries (counting the replies to each), watching `P/obj/*/state`."""
    import msgpack
    import zenoh

    from clients import Client
    from clients.demo.world import global_to_cell
    from engine.geometry import Position, Vec3
    from service.protocol.codec import encode_mover_spec, encode_position
    from service.bus.zconfig import make_config
    from support.service_harness import human

    session = zenoh.open(make_config(connect=[router]))
    published: list[int] = []
    lock = threading.Lock()

    def on_state(sample: Any) -> None:
        st = msgpack.unpackb(sample.payload.to_bytes(), raw=False)["state"]
        with lock:
            published.append(st["seq"])

    out: dict[str, Any] = {"replies": [], "seqs": [], "landblocks": [], "errors": []}
    try:
        with Client(session=session, timeout=10.0) as c:
            out["instances"] = len(c.wait_ready(instances=2, timeout=30.0))
            sub = session.declare_subscriber("acphys/obj/*/state", on_state)

            def query(key: str, content: dict[str, Any]) -> list[Any]:
                return list(session.get(key, payload=msgpack.packb({"v": 1, **content}),
                                        consolidation=zenoh.ConsolidationMode.NONE, timeout=10.0))

            cell, x, y = global_to_cell(180.0, 100.0)
            (reg,) = query(f"acphys/lb/{cell >> 16:04X}/register",
                           {"mover": encode_mover_spec(human()), "position": encode_position(Position.at(cell, Vec3(x, y, 80.0)))})
            state = msgpack.unpackb(reg.ok.payload.to_bytes(), raw=False)["state"]
            mover = state["id"]
            deadline = time.monotonic() + 20.0
            while time.monotonic() < deadline:  # fall to the ground; until a state is seen, the subscription is not live
                (rep,) = query(f"acphys/lb/{state['landblock']:04X}/move", {"move": {"id": mover, "motion": [0, 0, 0], "dt": 0.2}})
                state = msgpack.unpackb(rep.ok.payload.to_bytes(), raw=False)["state"]
                time.sleep(0.05)
                with lock:
                    if state["seq"] in published and state["contact"]:
                        break
            out["base_seq"] = state["seq"]
            for dx in [1.0] * 25 + [-1.0] * 25:
                replies = query(f"acphys/lb/{state['landblock']:04X}/move", {"move": {"id": mover, "offset": [dx, 0, 0]}})
                out["replies"].append(len(replies))
                ok = [r for r in replies if r.ok is not None]
                if not ok:
                    out["errors"].append([r.err.payload.to_bytes().decode("utf-8", "replace") for r in replies])
                    break
                state = msgpack.unpackb(ok[0].ok.payload.to_bytes(), raw=False)["state"]
                out["seqs"].append(state["seq"])
                out["landblocks"].append(state["landblock"])
            end = time.monotonic() + 10.0
            while time.monotonic() < end:
                with lock:
                    if published and published[-1] >= state["seq"]:
                        break
                time.sleep(0.05)
            with lock:
                out["published"] = [s for s in published if s > out["base_seq"]]
            out["handovers_in"] = sum(s["handovers"]["in"] for s in c.stats())
            # a forged hand-over from this plain client: the router's access control drops it where it enters
            forged = {"id": 0x5151, "seq": 99, "from": "forger", "mover": encode_mover_spec(human()),
                      "position": encode_position(Position.at(cell, Vec3(x, y, 80.0)))}
            out["forged_replies"] = len(query(f"acphys/lb/{cell >> 16:04X}/handover", forged))
            out["handovers_in_after_forgery"] = sum(s["handovers"]["in"] for s in c.stats())
            sub.undeclare()
    finally:
        session.close()
    return out
