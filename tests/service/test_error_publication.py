"""Where a pushed move's error goes (docs/protocol.md, "Object error"), on a real node and a real watcher:
on its mover's error key, and only while someone subscribes to an error key; a held mover's key declared
at its first error and let go when the mover leaves, an unknown id's never declared
(service/bus/publication.py, `publish_error`)."""

from __future__ import annotations

import threading
from collections import Counter
from typing import Any

import msgpack
import pytest
import zenoh

from clients.demo.world import global_to_cell
from engine import load_scene
from service.bus.node import NodeOptions, ServiceNode
from service.bus.zconfig import make_config
from support.service_harness import DEMO_SCENE, endpoint, free_port, raw_session, register_human, wait_until

P = "acphys"
UNKNOWN = 0xBEEF


class CountingSession:
    """The node's session, with every put counted by its key's text, and every put on a key declared on this
    session (a KeyExpr) and every declaration and undeclaration recorded (and each passed on)."""

    def __init__(self, session: Any) -> None:
        self._session = session
        self.puts: Counter[str] = Counter()
        self.declared_puts: list[str] = []
        self.calls: list[tuple[str, str]] = []

    def put(self, key: Any, payload: Any) -> None:
        self.puts[str(key)] += 1
        if isinstance(key, zenoh.KeyExpr):
            self.declared_puts.append(str(key))
        self._session.put(key, payload)

    def declare_keyexpr(self, key: str) -> Any:
        self.calls.append(("declare", key))
        return self._session.declare_keyexpr(key)

    def undeclare(self, kx: Any) -> None:
        self.calls.append(("undeclare", str(kx)))
        self._session.undeclare(kx)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._session, name)


def _started(options: NodeOptions) -> tuple[ServiceNode, str]:
    where = endpoint(free_port())
    n = ServiceNode(load_scene(str(DEMO_SCENE)), make_config(listen=[where]), options)
    n.start()
    return n, where


@pytest.fixture()
def node() -> Any:
    n, where = _started(NodeOptions())
    try:
        yield n, where
    finally:
        n.shutdown(timeout=5.0)


def _counted(n: ServiceNode) -> tuple[int, Any, CountingSession]:
    """A mover registered in `n`, `n`'s bus, and the bus's session now counted."""
    mid = register_human(n.core)
    bus = n.bus
    assert bus is not None
    counting = bus.session = CountingSession(bus.session)
    return mid, bus, counting


def _push_failing(sender: zenoh.Session, mover_id: int) -> None:
    """One push of two failing moves: the held mover's (an infinite offset) and an unknown id's."""
    cell, _x, _y = global_to_cell(40.0, 40.0)
    sender.put(f"{P}/lb/{cell >> 16:04X}/push",
               msgpack.packb({"v": 1, "moves": [{"id": mover_id, "offset": [float("inf"), 0.0, 0.0]},
                                                {"id": UNKNOWN, "offset": [0.5, 0.0, 0.0]}]}))


def test_a_held_movers_error_key_is_declared_once_and_let_go_with_the_mover(node: Any) -> None:
    n, where = node
    watcher = raw_session(where)
    got: list[tuple[str, str, int]] = []
    lock = threading.Lock()

    def on_sample(sample: Any) -> None:
        msg = msgpack.unpackb(sample.payload.to_bytes(), raw=False)
        with lock:
            got.append((str(sample.key_expr), msg["error"]["kind"], msg["id"]))

    try:
        mid = register_human(n.core)
        sub = watcher.declare_subscriber(f"{P}/obj/*/error", on_sample)
        assert wait_until(n.bus.errors_watched, timeout=10.0)
        for _ in range(2):
            _push_failing(watcher, mid)
        held_key, unknown_key = f"{P}/obj/{mid:X}/error", f"{P}/obj/{UNKNOWN:X}/error"
        expected = [(held_key, "non_finite", mid), (unknown_key, "unknown_mover", UNKNOWN)] * 2
        assert wait_until(lambda: len(got) >= 4, timeout=10.0), got
        assert got == expected  # one sender, one instance: in the order the moves were pushed
        route_keys = n._route_keys
        assert route_keys is not None
        assert isinstance(route_keys.declared.get(held_key), zenoh.KeyExpr)
        assert unknown_key not in route_keys.declared  # ids are the sender's to choose: never kept
        assert n.core is not None
        n.core.remove(mid)
        assert held_key not in route_keys.declared and f"{P}/obj/{mid:X}/state" not in route_keys.declared
        sub.undeclare()
    finally:
        watcher.close()


def test_no_error_is_put_while_nobody_subscribes_to_an_error_key(node: Any) -> None:
    n, where = node
    sender = raw_session(where)
    try:
        mid, bus, counting = _counted(n)
        stats = n.stats
        before = dict(stats.errors)
        _push_failing(sender, mid)
        # both moves were answered (counted), and nothing was put for them
        assert wait_until(lambda: sum(stats.errors.values()) - sum(before.values()) == 2, timeout=10.0)
        assert not any(k.endswith("/error") for k in counting.puts), counting.puts
        # once someone subscribes, the same push is put on both keys
        got: list[str] = []
        sub = sender.declare_subscriber(f"{P}/obj/{UNKNOWN:X}/error", lambda s: got.append(str(s.key_expr)))
        assert wait_until(bus.errors_watched, timeout=10.0)
        _push_failing(sender, mid)
        assert wait_until(lambda: bool(got), timeout=10.0)
        held_key, unknown_key = f"{P}/obj/{mid:X}/error", f"{P}/obj/{UNKNOWN:X}/error"
        assert counting.puts[held_key] == 1 and counting.puts[unknown_key] == 1
        assert got == [unknown_key]
        # both put on declared keys: the unknown id's declared for that put alone, then let go
        assert counting.declared_puts == [held_key, unknown_key]
        assert [c for c in counting.calls if c[1] == unknown_key] == [("declare", unknown_key), ("undeclare", unknown_key)]
        sub.undeclare()
    finally:
        sender.close()


def test_a_node_on_direct_callbacks_declares_no_error_key() -> None:
    """Direct callbacks run on Zenoh's own threads, which declare nothing (service/bus/route_keys.py): an
    unknown id's error goes on its key's text, and is received."""
    n, where = _started(NodeOptions(direct_callbacks=True))
    watcher = raw_session(where)
    try:
        mid, bus, counting = _counted(n)
        got: list[str] = []
        sub = watcher.declare_subscriber(f"{P}/obj/*/error", lambda s: got.append(str(s.key_expr)))
        assert wait_until(bus.errors_watched, timeout=10.0)
        _push_failing(watcher, mid)
        unknown_key = f"{P}/obj/{UNKNOWN:X}/error"
        assert wait_until(lambda: unknown_key in got, timeout=10.0), got
        assert counting.calls == [] and counting.puts[unknown_key] == 1
        assert unknown_key not in counting.declared_puts
        sub.undeclare()
    finally:
        watcher.close()
        n.shutdown(timeout=5.0)
