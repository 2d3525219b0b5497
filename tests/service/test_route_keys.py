"""The literal keys a node declares on its session (service/bus/route_keys.py): each new request key that
names one landblock, once, up to the limit, and each held mover's State key, once, whatever the count; none
for a wildcard or refused key;
all undeclared at shutdown; the requests on them answered and the States on them received as before."""

from __future__ import annotations


import threading
from typing import Any

import msgpack
import pytest
import zenoh

from clients.demo.world import global_to_cell
from engine import load_scene
from service.bus.key_landblocks import KeyLandblocks
from service.bus.node import NodeOptions, ServiceNode
from service.bus.route_keys import RouteKeys
from service.bus.zconfig import make_config
from service.protocol.errors import ProtocolError
from service.protocol.wire import Keys
from support.service_harness import DEMO_SCENE, endpoint, free_port, raw_query, raw_session, register_human, wait_until


class RecordingSession:
    """What RouteKeys asks of a session, recorded; `fail` makes every declaration raise."""

    def __init__(self, fail: bool = False) -> None:
        self.fail = fail
        self.declared: list[str] = []
        self.undeclared: list[str] = []

    def declare_keyexpr(self, key: str) -> str:
        if self.fail:
            raise RuntimeError("session closed")
        self.declared.append(key)
        return f"kx:{key}"

    def undeclare(self, kx: str) -> None:
        self.undeclared.append(kx)


def test_each_key_is_declared_once_and_never_past_the_limit() -> None:
    s = RecordingSession()
    rk = RouteKeys(s, limit=2)
    for key in ("p/lb/0101/move", "p/lb/0101/move", "p/lb/0102/move", "p/lb/0103/move", "p/lb/0101/move"):
        rk.learn(key)
    assert s.declared == ["p/lb/0101/move", "p/lb/0102/move"]  # the third new key is past the limit
    rk.close()
    assert sorted(s.undeclared) == ["kx:p/lb/0101/move", "kx:p/lb/0102/move"] and rk.declared == {}


def test_a_declaration_that_fails_is_not_an_error_and_is_tried_again() -> None:
    s = RecordingSession(fail=True)
    rk = RouteKeys(s)
    rk.learn("p/lb/0101/move")  # nothing raised: the key is served by matching, as without it
    assert rk.declared == {}
    s.fail = False
    rk.learn("p/lb/0101/move")
    assert s.declared == ["p/lb/0101/move"]


def test_every_held_movers_state_key_is_declared_whatever_the_request_keys_limit() -> None:
    s = RecordingSession()
    rk = RouteKeys(s, limit=1)
    rk.learn("p/lb/0101/move")
    rk.learn("p/lb/0102/move")  # past the request keys' limit: not declared
    first = rk.key_expr("p/obj/1/state")
    assert first == "kx:p/obj/1/state" and rk.key_expr("p/obj/1/state") is first  # declared once
    assert [rk.key_expr(f"p/obj/{i}/state") for i in (2, 3)] == ["kx:p/obj/2/state", "kx:p/obj/3/state"]
    assert s.declared == ["p/lb/0101/move", "p/obj/1/state", "p/obj/2/state", "p/obj/3/state"]
    rk.learn("p/lb/0103/move")  # the State keys took no request key's place
    assert "p/lb/0103/move" not in s.declared


def test_a_state_key_the_session_will_not_declare_is_put_on_parsed() -> None:
    s = RecordingSession(fail=True)
    rk = RouteKeys(s)
    past = rk.key_expr("p/obj/2/state")
    assert isinstance(past, zenoh.KeyExpr) and str(past) == "p/obj/2/state" and rk.declared == {}


def test_a_forgotten_key_is_undeclared() -> None:
    s = RecordingSession()
    rk = RouteKeys(s, limit=1)
    rk.key_expr("p/obj/1/state")
    rk.forget("p/obj/1/state")
    rk.forget("p/obj/9/state")  # never declared: nothing to undo
    assert s.undeclared == ["kx:p/obj/1/state"] and rk.declared == {}
    assert rk.key_expr("p/obj/1/state") == "kx:p/obj/1/state" and s.declared == ["p/obj/1/state"] * 2


def test_close_undeclares_both_kinds_and_starts_the_count_again() -> None:
    s = RecordingSession()
    rk = RouteKeys(s, limit=1)
    rk.learn("p/lb/0101/move")
    rk.key_expr("p/obj/1/state")
    rk.close()
    assert sorted(s.undeclared) == ["kx:p/lb/0101/move", "kx:p/obj/1/state"] and rk.declared == {}
    rk.learn("p/lb/0102/move")
    assert s.declared[-1] == "p/lb/0102/move"


def test_only_new_keys_naming_one_landblock_are_learned() -> None:
    learned: list[str] = []
    kl = KeyLandblocks(Keys("acphys"))
    kl.learned = learned.append
    for _ in range(2):  # a remembered key is not learned again
        assert kl.landblock("acphys/lb/A9B4/move", "move") == 0xA9B4
        assert kl.landblock("acphys/lb/*/get", "get") is None  # a wildcard names no landblock
        with pytest.raises(ProtocolError):
            kl.landblock("acphys/lb/ZZ00/move", "move")  # refused
    assert learned == ["acphys/lb/A9B4/move"]


def _started(options: NodeOptions) -> tuple[ServiceNode, str]:
    where = endpoint(free_port())
    n = ServiceNode(load_scene(str(DEMO_SCENE)), make_config(listen=[where]), options)
    n.start()
    return n, where


def test_a_node_declares_the_keys_it_is_asked_on_and_answers_as_before() -> None:
    node, where = _started(NodeOptions())
    client = raw_session(where)
    try:
        mid = register_human(node.core)
        cell, _x, _y = global_to_cell(40.0, 40.0)
        key = f"acphys/lb/{cell >> 16:04X}/move"
        route_keys = node._route_keys
        assert route_keys is not None

        def request_keys() -> list[str]:
            return [k for k in route_keys.declared if k.startswith("acphys/lb/")]

        assert request_keys() == []
        seqs = []
        for _ in range(3):  # the first on an undeclared key, the others on the declared one
            ok, reply = raw_query(client, key, msgpack.packb({"v": 1, "move": {"id": mid, "offset": [0.5, 0.0, 0.0]}}))
            assert ok, reply
            seqs.append(reply["state"]["seq"])
        assert seqs == [1, 2, 3]
        ok, reply = raw_query(client, "acphys/lb/*/get", msgpack.packb({"v": 1, "id": mid}))
        assert ok and reply["state"]["id"] == mid
        assert request_keys() == [key]  # the wildcard `get` declared nothing
        assert isinstance(route_keys.declared[key], zenoh.KeyExpr)
    finally:
        client.close()
        node.shutdown(timeout=5.0)
    assert node._route_keys is None and route_keys.declared == {}  # undeclared before the session closed


def test_a_node_on_direct_callbacks_declares_nothing() -> None:
    node, where = _started(NodeOptions(direct_callbacks=True))
    client = raw_session(where)
    try:
        mid = register_human(node.core)
        cell, _x, _y = global_to_cell(40.0, 40.0)
        ok, reply = raw_query(client, f"acphys/lb/{cell >> 16:04X}/move",
                              msgpack.packb({"v": 1, "move": {"id": mid, "offset": [0.5, 0.0, 0.0]}}))
        assert ok and reply["state"]["seq"] == 1
        assert node._route_keys is None
    finally:
        client.close()
        node.shutdown(timeout=5.0)


class StatesSeen:
    """A State subscriber's callback: what it received, as (key, seq), in arrival order. `moves()` leaves out
    the registers' States (seq 0): one put before the subscription may still reach it (Zenoh sends a newly
    connected peer everything until that peer has told its subscriptions, and the watcher hands a queued
    sample to a subscriber declared meanwhile)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._got: list[tuple[str, int]] = []

    def __call__(self, sample: Any) -> None:
        seq = msgpack.unpackb(sample.payload.to_bytes(), raw=False)["state"]["seq"]
        with self._lock:
            self._got.append((str(sample.key_expr), seq))

    def all(self) -> list[tuple[str, int]]:
        with self._lock:
            return list(self._got)

    def moves(self) -> list[tuple[str, int]]:
        return [g for g in self.all() if g[1] >= 1]


def _move(session: zenoh.Session, mover_id: int) -> None:
    """One move of the mover at the demo start, asked over the bus; it must resolve."""
    cell, _x, _y = global_to_cell(40.0, 40.0)
    ok, _reply = raw_query(session, f"acphys/lb/{cell >> 16:04X}/move",
                           msgpack.packb({"v": 1, "move": {"id": mover_id, "offset": [0.5, 0.0, 0.0]}}))
    assert ok


def test_a_published_state_goes_out_on_its_declared_key_and_is_received() -> None:
    node, where = _started(NodeOptions())
    watcher = raw_session(where)
    seen = StatesSeen()
    try:
        mid = register_human(node.core)
        state_key = f"acphys/obj/{mid:X}/state"
        sub = watcher.declare_subscriber(state_key, seen)
        bus = node.bus
        assert bus is not None and wait_until(bus.states_watched, timeout=10.0)
        for _ in range(2):  # the first put declares the key, the second takes its route
            _move(watcher, mid)
        assert wait_until(lambda: len(seen.moves()) >= 2, timeout=10.0), seen.all()
        assert seen.moves() == [(state_key, 1), (state_key, 2)]
        assert node._route_keys is not None and state_key in node._route_keys.declared
        assert node.core is not None
        node.core.remove(mid)  # the mover leaves: its State key is let go
        assert state_key not in node._route_keys.declared
        sub.undeclare()
    finally:
        watcher.close()
        node.shutdown(timeout=5.0)


def test_a_node_past_its_request_keys_limit_still_publishes_every_state_on_a_declared_key() -> None:
    node, where = _started(NodeOptions())
    watcher = raw_session(where)
    seen = StatesSeen()
    try:
        route_keys = node._route_keys
        assert route_keys is not None
        route_keys.limit = 0  # no request key may be declared: the State keys must not depend on it
        movers = [register_human(node.core) for _ in range(3)]
        sub = watcher.declare_subscriber("acphys/obj/*/state", seen)
        bus = node.bus
        assert bus is not None and wait_until(bus.states_watched, timeout=10.0)
        for mid in movers:
            _move(watcher, mid)
        state_keys = [f"acphys/obj/{mid:X}/state" for mid in movers]
        assert wait_until(lambda: sorted(k for k, _seq in seen.moves()) == sorted(state_keys), timeout=10.0), seen.all()
        assert all(isinstance(route_keys.declared[k], zenoh.KeyExpr) for k in state_keys)
        assert not any(k.startswith("acphys/lb/") for k in route_keys.declared)
        sub.undeclare()
    finally:
        watcher.close()
        node.shutdown(timeout=5.0)


def test_a_mover_registered_while_nobody_watches_has_no_state_key_until_its_first_watched_state() -> None:
    node, where = _started(NodeOptions())
    watcher = raw_session(where)
    seen = StatesSeen()
    try:
        route_keys, bus = node._route_keys, node.bus
        assert route_keys is not None and bus is not None and not bus.states_watched()
        quiet = register_human(node.core)
        # unwatched, the register's State is not put, so its key is not declared (a declaration costs more
        # the more keys are declared: docs/performance.md, "Many movers")
        assert f"acphys/obj/{quiet:X}/state" not in route_keys.declared
        sub = watcher.declare_subscriber("acphys/obj/*/state", seen)
        assert wait_until(bus.states_watched, timeout=10.0)
        watched = register_human(node.core)  # watched: its State is put, on its key declared now
        assert isinstance(route_keys.declared.get(f"acphys/obj/{watched:X}/state"), zenoh.KeyExpr)
        _move(watcher, quiet)  # the quiet mover's first watched State declares its key
        expected = [(f"acphys/obj/{watched:X}/state", 0), (f"acphys/obj/{quiet:X}/state", 1)]
        assert wait_until(lambda: len(seen.all()) >= 2, timeout=10.0), seen.all()
        assert sorted(seen.all()) == sorted(expected)
        assert isinstance(route_keys.declared.get(f"acphys/obj/{quiet:X}/state"), zenoh.KeyExpr)
        sub.undeclare()
    finally:
        watcher.close()
        node.shutdown(timeout=5.0)
