"""A new client reaches every instance of a cluster, every time: `acphys stats` lists both of the README's
two instances (B connects to A's TLS endpoint; the command connects to A's plain one) and both of two
instances behind a router; `acphys move` through A reaches B's landblock.

A new peer session meets B through Zenoh's gossip about 0.1 s after it opens; asked sooner, only A
answered (1 of 2 instances in about half the tries), and a request to B's landblock found nobody. The
client waits until it is `SETTLE_S` old before a query to every instance, and asks again then when
nobody answered a landblock's request (clients/client.py).
"""

from __future__ import annotations

import re
import subprocess
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from clients import Client
from support.cluster_files import cluster_file, make_certificates, tls_endpoint
from support.service_harness import DEMO_SCENE, ROOT, ServiceProcess, child_env, free_port

TRIES = 20  # the README recipe; behind a router, ROUTER_TRIES
ROUTER_TRIES = 10
MOVE_TRIES = 10


def _listed(endpoint: str) -> list[str]:
    """The instances one `acphys stats --connect endpoint` lists (a process of its own, as a user runs it:
    inside a process whose Zenoh runtime is already running, the new session meets B sooner)."""
    r = subprocess.run([sys.executable, "-m", "clients", "stats", "--connect", endpoint], cwd=ROOT,
                       env=child_env(), capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    return sorted(re.findall(r"^instance (\S+)$", r.stdout, re.MULTILINE))


def _every_try_lists_both(endpoint: str, tries: int = TRIES) -> None:
    with Client([endpoint], timeout=10.0) as c:
        want = sorted(h.instance for h in c.wait_ready(instances=2, timeout=30.0))
    assert len(want) == 2
    got = [_listed(endpoint) for _ in range(tries)]
    assert got == [want] * tries, [len(g) for g in got]


@contextmanager
def _readme_cluster(tmp_path: Path) -> Iterator[ServiceProcess]:
    """The README's two instances: A owns A9B4,A9B5, B owns AAB4,AAB5 and connects to A's TLS endpoint;
    A's plain endpoint is what the commands connect to."""
    make_certificates(tmp_path)
    a_tls, b_tls = tls_endpoint(), tls_endpoint()
    a = cluster_file(tmp_path, "a", [a_tls], [])
    b = cluster_file(tmp_path, "b", [b_tls], [a_tls])
    with ServiceProcess(own="A9B4,A9B5", extra=["--cluster", str(a)]) as first, \
            ServiceProcess(own="AAB4,AAB5", extra=["--cluster", str(b)]):
        yield first


def test_the_readme_cluster_lists_both_instances_every_time(tmp_path: Path) -> None:
    with _readme_cluster(tmp_path) as first:
        _every_try_lists_both(first.endpoint)


def test_a_move_in_the_other_instances_landblock_reaches_it_every_time(tmp_path: Path) -> None:
    """`acphys move` connected to A registers, moves and removes a mover in AAB4, B's landblock."""
    with _readme_cluster(tmp_path) as first:
        with Client([first.endpoint], timeout=10.0) as c:
            c.wait_ready(instances=2, timeout=30.0)
        for _ in range(MOVE_TRIES):
            r = subprocess.run([sys.executable, "-m", "clients", "move", "--start", "AAB40001", "20", "20", "60",
                                "--offset", "1", "0", "0", "--connect", first.endpoint], cwd=ROOT, env=child_env(),
                               capture_output=True, text=True, timeout=60)
            assert r.returncode == 0, r.stderr


@contextmanager
def _running(args: list[str], ready: str) -> Iterator[subprocess.Popen[str]]:
    proc = subprocess.Popen(args, cwd=ROOT, env=child_env(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True)
    seen = threading.Event()
    lines: list[str] = []

    def pump() -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            lines.append(line)
            if ready in line:
                seen.set()

    threading.Thread(target=pump, daemon=True).start()
    try:
        assert seen.wait(60.0), "".join(lines)
        yield proc
    finally:
        proc.terminate()
        try:
            proc.wait(20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(10)


def test_two_instances_behind_a_router_are_both_listed_every_time(tmp_path: Path) -> None:
    make_certificates(tmp_path)
    router_tls, router_plain = tls_endpoint(), f"tcp/127.0.0.1:{free_port()}"
    router = cluster_file(tmp_path, "router", [router_tls], [])
    member = cluster_file(tmp_path, "member", [], [router_tls])

    def instance(own: str) -> list[str]:
        return [sys.executable, "-m", "service", "--scene", str(DEMO_SCENE), "--own", own, "--mode", "client",
                "--listen", f"tcp/127.0.0.1:{free_port()}", "--cluster", str(member), "--log-level", "WARNING"]

    with _running([sys.executable, "-m", "clients", "router", "--listen", router_plain, "--cluster", str(router),
                   "--log-level", "WARNING"], "acphys router ready"), \
            _running(instance("A9B4,A9B5"), "acphys service ready"), \
            _running(instance("AAB4,AAB5"), "acphys service ready"):
        _every_try_lists_both(router_plain, ROUTER_TRIES)
