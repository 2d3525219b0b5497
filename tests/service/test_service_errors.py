"""Bad input of every kind gets an error naming the problem, and the service
keeps answering everyone else with their state untouched."""

from __future__ import annotations

import re

import threading
from collections.abc import Iterator
from typing import Any

import msgpack
import pytest
import zenoh

from clients import Client, ServiceError
from clients.demo.world import global_to_cell
from engine.geometry import Position, Vec3
from service.protocol.codec import encode_mover_spec
from support.service_harness import ServiceProcess, comparable, human, raw_query, wait_until

P = "acphys"


@pytest.fixture(scope="module")
def bystander(service: ServiceProcess) -> Iterator[tuple[Client, int]]:
    """Another client's mover, checked untouched after every bad request."""
    with Client([service.endpoint]) as c:
        c.wait_ready()
        cell, x, y = global_to_cell(50.0, 300.0)
        st = c.register(human(), Position.at(cell, Vec3(x, y, 70.0)))
        yield c, st.id


def pk(obj: Any) -> bytes:
    return msgpack.packb(obj, use_bin_type=True)


CELL, X, Y = global_to_cell(30.0, 30.0)
GOOD_POS = {"cell": CELL, "origin": [X, Y, 60.0]}
GOOD_SPEC = encode_mover_spec(human())

# (name, key op, payload bytes or None, expected kind, expected path or None)
CASES: list[tuple[str, str, bytes | None, str, str | None]] = [
    ("not msgpack", "move", b"\xc1\xc1\xc1", "malformed", None),
    ("truncated msgpack", "move", pk({"v": 1, "move": {"id": 1}})[:-3], "malformed", None),
    ("empty payload", "move", None, "malformed", None),
    ("not a map", "move", pk([1, 2, 3]), "malformed", None),
    ("no version", "move", pk({"move": {"id": 1, "offset": [0, 0, 0]}}), "missing_field", "v"),
    ("version 2", "move", pk({"v": 2, "move": {"id": 1, "offset": [0, 0, 0]}}), "unsupported_version", "v"),
    ("version as string", "register", pk({"v": "1"}), "wrong_type", "v"),
    ("neither move nor moves", "move", pk({"v": 1}), "missing_field", None),
    ("move is a list", "move", pk({"v": 1, "move": [1, 2]}), "wrong_type", "move"),
    ("moves not a list", "move", pk({"v": 1, "moves": {"id": 1}}), "wrong_type", "moves"),
    ("id missing", "move", pk({"v": 1, "move": {"offset": [0, 0, 0]}}), "missing_field", "move.id"),
    ("id negative", "move", pk({"v": 1, "move": {"id": -4, "offset": [0, 0, 0]}}), "bad_value", "move.id"),
    ("id is bool", "move", pk({"v": 1, "move": {"id": True, "offset": [0, 0, 0]}}), "wrong_type", "move.id"),
    ("offset of 2", "move", pk({"v": 1, "move": {"id": 1, "offset": [0, 0]}}), "bad_value", "move.offset"),
    ("offset string", "move", pk({"v": 1, "move": {"id": 1, "offset": ["a", 0, 0]}}), "wrong_type", "move.offset[0]"),
    ("NaN", "move", pk({"v": 1, "move": {"id": 1, "offset": [float("nan"), 0, 0]}}), "non_finite", "move.offset[0]"),
    ("inf", "move", pk({"v": 1, "move": {"id": 1, "to": {"origin": [0, float("inf"), 0]}}}), "non_finite",
     "move.to.origin[1]"),
    ("to and offset", "move", pk({"v": 1, "move": {"id": 1, "offset": [0, 0, 0], "to": {"origin": [0, 0, 0]}}}),
     "bad_value", "move"),
    ("motion without dt", "move", pk({"v": 1, "move": {"id": 1, "motion": [0, 0, 0]}}), "missing_field", "move.dt"),
    ("dt zero", "move", pk({"v": 1, "move": {"id": 1, "motion": [0, 0, 0], "dt": 0}}), "bad_value", "move.dt"),
    ("bad quaternion", "move", pk({"v": 1, "move": {"id": 1, "to": {"origin": [0, 0, 0], "orientation": [2, 0, 0, 0]}}}),
     "bad_value", "move.to.orientation"),
    ("unknown mover", "move", pk({"v": 1, "move": {"id": 123456789, "offset": [0, 0, 0]}}), "unknown_mover", "move.id"),
    ("register without mover", "register", pk({"v": 1, "position": GOOD_POS}), "missing_field", "mover"),
    ("register negative radius", "register",
     pk({"v": 1, "position": GOOD_POS, "mover": {"spheres": [{"center": [0, 0, 0], "radius": -1}]}}),
     "bad_value", "mover.spheres[0].radius"),
    ("register unknown flag", "register",
     pk({"v": 1, "position": GOOD_POS, "mover": {**GOOD_SPEC, "state": ["Flying"]}}), "bad_value", "mover.state[0]"),
    ("register no spheres", "register", pk({"v": 1, "position": GOOD_POS, "mover": {"spheres": []}}),
     "bad_value", "mover.spheres"),
    ("register invalid cell index", "register",
     pk({"v": 1, "mover": GOOD_SPEC, "position": {"cell": (0xA9B4 << 16) | 0xFFFF, "origin": [1, 1, 1]}}),
     "unknown_cell", None),
    ("register missing env cell", "register",
     pk({"v": 1, "mover": GOOD_SPEC, "position": {"cell": (0xA9B4 << 16) | 0x0123, "origin": [1, 1, 1]}}),
     "unknown_cell", None),
    ("register unloaded landblock", "register",
     pk({"v": 1, "mover": GOOD_SPEC, "position": {"cell": 0x12340001, "origin": [1, 1, 1]}}),
     "landblock_not_loaded", None),
    ("register id zero", "register", pk({"v": 1, "id": 0, "mover": GOOD_SPEC, "position": GOOD_POS}), "bad_value", "id"),
    ("register cell too big", "register",
     pk({"v": 1, "mover": GOOD_SPEC, "position": {"cell": 1 << 40, "origin": [1, 1, 1]}}), "bad_value",
     "position.cell"),
    ("remove unknown", "remove", pk({"v": 1, "id": 77}), "unknown_mover", "id"),
    ("get without id", "get", pk({"v": 1}), "missing_field", "id"),
    ("update bad spec", "update", pk({"v": 1, "id": 77, "mover": {"spheres": "x"}}), "wrong_type", "mover.spheres"),
    ("load unknown landblock", "load", None, "landblock_unavailable", None),
    ("unload not loaded", "unload", pk({"v": 1}), "landblock_not_loaded", None),
    ("map with int keys", "move", pk({1: 2, "v": 1}), "wrong_type", None),
    ("ext type", "move", pk({"v": 1, "move": {"id": msgpack.ExtType(5, b"x"), "offset": [0, 0, 0]}}), "wrong_type",
     "move.id"),
]


def _lb_for(op: str, name: str) -> str:
    # load/unload cases target landblocks that are not there
    if op == "load":
        return "1234"
    if op == "unload":
        return "5678"
    return "A9B4"


@pytest.mark.parametrize("name,op,payload,kind,path", CASES, ids=[c[0] for c in CASES])
def test_bad_request_gets_a_named_error(session: zenoh.Session, bystander: tuple[Client, int], name: str, op: str,
                                        payload: bytes | None, kind: str, path: str | None) -> None:
    client, mover_id = bystander
    before = comparable(client.get(mover_id)[0])
    ok, reply = raw_query(session, f"{P}/lb/{_lb_for(op, name)}/{op}", payload)
    assert not ok, reply
    assert reply["v"] == 1
    err = reply["error"]
    assert err["kind"] == kind, err
    assert isinstance(err["message"], str) and err["message"]
    # no class name of Python's or msgpack's in what a client reads (ExtraData, ValueError, OutOfRangeError...)
    assert not re.search(r"\b[A-Z][A-Za-z]*(Error|Exception|Data)\b", err["message"]), err["message"]
    if path is not None:
        assert err.get("path") == path, err
    # the service is still up, and the other client's mover is as it was
    after, _ = client.get(mover_id)
    assert comparable(after) == before
    assert client.move(mover_id, offset=(0.0, 0.0, 0.0)).ok


def test_bad_key_landblock(session: zenoh.Session) -> None:
    ok, reply = raw_query(session, f"{P}/lb/ZZZZ/move", pk({"v": 1, "move": {"id": 1, "offset": [0, 0, 0]}}))
    assert not ok and reply["error"]["kind"] == "bad_value"


def test_bad_pushes_are_reported_on_the_error_keys(service: ServiceProcess, session: zenoh.Session,
                                                   bystander: tuple[Client, int]) -> None:
    client, mover_id = bystander
    got: list[tuple[str, dict[str, Any]]] = []
    lock = threading.Lock()

    def on_sample(s: zenoh.Sample) -> None:
        with lock:
            got.append((str(s.key_expr), msgpack.unpackb(s.payload.to_bytes(), raw=False)))

    subs = [session.declare_subscriber(f"{P}/errors", on_sample), session.declare_subscriber(f"{P}/obj/*/error", on_sample)]
    try:
        # bad pushes until one is answered: the subscriptions are live
        for _ in range(50):
            session.put(f"{P}/lb/A9B4/push", b"\xc1")
            if wait_until(lambda: bool(got), timeout=0.2):
                break
        session.put(f"{P}/lb/A9B4/push", b"\x93garbage")
        session.put(f"{P}/lb/A9B4/push", pk({"v": 9, "move": {"id": 1, "offset": [0, 0, 0]}}))
        session.put(f"{P}/lb/A9B4/push", pk({"v": 1, "moves": [{"id": 0xBEEF, "offset": [0, 0, 0], "tag": "t1"},
                                                              {"id": mover_id, "offset": [float("inf"), 0, 0]}]}))
        expected = {
            (f"{P}/errors", "malformed"),
            (f"{P}/errors", "unsupported_version"),
            (f"{P}/obj/BEEF/error", "unknown_mover"),
            (f"{P}/obj/{mover_id:X}/error", "non_finite"),
        }
        assert wait_until(lambda: expected <= {(k, m["error"]["kind"]) for k, m in list(got)}, timeout=10.0), got
    finally:
        for s in subs:
            s.undeclare()
    beef = next(m for k, m in got if k.endswith("BEEF/error"))
    assert beef["id"] == 0xBEEF and beef["tag"] == "t1" and beef["v"] == 1
    assert client.move(mover_id, offset=(0.0, 0.0, 0.0)).ok


def test_client_raises_clear_exceptions(service: ServiceProcess) -> None:
    from clients import NoServiceError

    with Client([service.endpoint], prefix="nobody-here", timeout=2.0) as c:
        with pytest.raises(NoServiceError):
            c.load_landblock(0xA9B4)
    with Client([service.endpoint]) as c:
        with pytest.raises(ServiceError) as e:
            c.register(human(), Position.at(0xA9B40001, Vec3(1.0, 1.0, float("nan"))))
        assert e.value.kind == "non_finite" and e.value.path == "position.origin[2]"
        assert "non_finite" in str(e.value)
