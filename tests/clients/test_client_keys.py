"""The client's per-landblock request keys: declared on its session once each (Zenoh then keeps their routes
cached), parsed instead when the session refuses, let go at `close`, and never more than the cache holds."""

from __future__ import annotations

import threading
from typing import Any

import msgpack
import pytest
import zenoh

import clients.client as client_module
from clients import Client, Move
from engine import MoveResult
from engine.geometry import Position, Vec3
from service.bus.zconfig import make_config
from service.protocol.codec import pack_state
from service.protocol.frames import state_message
from support.service_harness import StandInReply, free_port
from support.sessions import SessionDouble

CELL = 0xA9B40001


def _state(mover_id: int, cell: int = CELL) -> bytes:
    result = MoveResult(True, Position.at(cell, Vec3(20.0, 20.0, 50.0)), "OK", True, True, None, cell, None, None,
                        False, 0, ["Contact", "OnWalkable"], [])
    return state_message(pack_state(mover_id, 1, result, []))


class _Session(SessionDouble):
    """Answers every request with mover 7's State in the landblock the key names; records the keys asked on."""

    def __init__(self) -> None:
        super().__init__()
        self.asked: list[Any] = []

    def get(self, key: Any, *, payload: bytes, timeout: float, **_options: Any) -> Any:
        self.asked.append(key)
        lb = int(str(key).split("/")[2], 16)
        state = _state(7, (lb << 16) | 1)
        if str(key).endswith("/get"):  # a get's reply: the State and the mover's spec
            reply = msgpack.unpackb(state)
            state = msgpack.packb({**reply, "mover": {"radius": 0.5}})
        return iter([StandInReply(ok=state)])


class _RefusingSession(_Session):
    def declare_keyexpr(self, key: str) -> zenoh.KeyExpr:
        raise zenoh.ZError("session closed")


def test_a_landblocks_key_is_declared_once_and_requests_go_on_it() -> None:
    session = _Session()
    client = Client(session=session)  # type: ignore[arg-type]
    client.locate(7, CELL >> 16)
    for d in (0.2, -0.2, 0.2):
        assert client.move(7, offset=(d, 0.0, 0.0)).id == 7
    assert client.get(7)[0].id == 7
    assert session.declared == ["acphys/lb/A9B4/move", "acphys/lb/A9B4/get"]
    assert [str(k) for k in session.asked] == ["acphys/lb/A9B4/move"] * 3 + ["acphys/lb/A9B4/get"]
    assert all(isinstance(k, zenoh.KeyExpr) for k in session.asked)


class _PushSession(_Session):
    """Records each put's key and payload."""

    def __init__(self) -> None:
        super().__init__()
        self.put_on: list[tuple[Any, bytes]] = []

    def put(self, key: Any, payload: bytes, **_options: Any) -> None:
        self.put_on.append((key, payload))


def test_a_push_goes_on_its_landblocks_declared_key() -> None:
    session = _PushSession()
    client = Client(session=session)  # type: ignore[arg-type]
    client.locate(7, 0xA9B4)
    client.locate(8, 0xA9B5)
    for d in (0.2, -0.2):
        client.push([Move(7, offset=(d, 0.0, 0.0)), Move(8, offset=(d, 0.0, 0.0))])
    # one put per landblock per push, each on the landblock's push key, declared once on the session
    assert session.declared == ["acphys/lb/A9B4/push", "acphys/lb/A9B5/push"]
    assert [str(k) for k, _ in session.put_on] == ["acphys/lb/A9B4/push", "acphys/lb/A9B5/push"] * 2
    assert all(isinstance(k, zenoh.KeyExpr) for k, _ in session.put_on)
    # the payload is the push as protocol.md writes it: one move, for one mover per landblock
    first = msgpack.unpackb(session.put_on[0][1])
    assert first == {"v": 1, "move": {"id": 7, "offset": [0.2, 0.0, 0.0]}}


def test_a_key_the_session_will_not_declare_is_sent_parsed() -> None:
    session = _RefusingSession()
    client = Client(session=session)  # type: ignore[arg-type]
    client.locate(7, CELL >> 16)
    assert client.move(7, offset=(0.2, 0.0, 0.0)).result.position.cell_id == CELL
    assert [str(k) for k in session.asked] == ["acphys/lb/A9B4/move"]
    assert isinstance(session.asked[0], zenoh.KeyExpr)


def test_close_lets_the_keys_go_on_a_session_given_to_the_client() -> None:
    session = _Session()
    client = Client(session=session)  # type: ignore[arg-type]
    client.locate(7, CELL >> 16)
    client.move(7, offset=(0.2, 0.0, 0.0))
    client.close()  # the session is the caller's: it stays open, the client's declarations do not
    client.move(7, offset=(0.2, 0.0, 0.0))
    assert session.declared == ["acphys/lb/A9B4/move"] * 2


def test_no_more_keys_are_kept_than_the_cache_holds(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(client_module, "_KEY_CACHE", 2)
    session = _Session()
    client = Client(session=session)  # type: ignore[arg-type]
    lbs = [0xA9B4, 0xA9B5, 0xA9B6, 0xA9B4]
    for lb in lbs:
        client.locate(7, lb)
        assert client.move(7, offset=(0.2, 0.0, 0.0)).result.position.cell_id >> 16 == lb
        assert len(client._lb_keys) <= 2
    # the third landblock emptied the cache, so the first one's key was declared again
    assert session.declared == [f"acphys/lb/{lb:04X}/move" for lb in lbs]


def test_a_declared_key_reaches_a_wildcard_queryable_on_another_session() -> None:
    """Through Zenoh itself: the service declares `P/lb/*/move`; the client's declared literal key finds it,
    and the reply comes back on it."""
    port = free_port()
    server = zenoh.open(make_config(listen=[f"tcp/127.0.0.1:{port}"]))
    asked: list[str] = []
    answered = threading.Event()

    def answer(query: zenoh.Query) -> None:
        asked.append(str(query.key_expr))
        query.reply(query.key_expr, _state(7))
        answered.set()

    queryable = server.declare_queryable("acphys/lb/*/move", answer)
    try:
        with Client([f"tcp/127.0.0.1:{port}"], timeout=5.0) as client:
            client.locate(7, CELL >> 16)
            for _ in range(50):  # the client's session meets the queryable some 0.1 s after it opens
                try:
                    client.move(7, offset=(0.2, 0.0, 0.0))
                    break
                except Exception:
                    threading.Event().wait(0.05)
            states = [client.move(7, offset=(0.2, 0.0, 0.0)) for _ in range(3)]
        assert [s.id for s in states] == [7, 7, 7]
        assert answered.is_set() and set(asked) == {"acphys/lb/A9B4/move"}
    finally:
        queryable.undeclare()
        server.close()
