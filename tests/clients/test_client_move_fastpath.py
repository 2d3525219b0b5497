"""`Client.send`'s short path (the landblock known, the reply a State in the service's shape) and its fall-backs
to the general routine: each other case is asked once per key and answered or raised as the general routine
answers or raises it (an unknown landblock found first, redirects followed, the settle retry, error and
timeout replies, a State in another shape), with a stand-in session answering without a service."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import msgpack
import pytest

from clients import Client, ServiceError
from clients.errors import NoServiceError, RequestTimeout
from clients.request_channel import FirstReplies, gather_state, pack_request
from clients.types import MoverState
from engine import MoveResult
from engine.geometry import Position, Vec3
from service.protocol.codec import pack_state
from service.protocol.frames import state_message
from support.service_harness import StandInReply as _Reply
from support.sessions import SessionDouble

CELL = 0xA9B40001
HERE, THERE = "acphys/lb/A9B4/move", "acphys/lb/A9B5/move"


def _state(lb: int = 0xA9B4, mover_id: int = 7) -> bytes:
    """A move's State reply as the service packs it, the mover in landblock `lb`."""
    result = MoveResult(True, Position.at((lb << 16) | 1, Vec3(20.0, 20.0, 50.0)), "OK", True, True, None,
                        (lb << 16) | 1, None, None, False, 0, ["Contact", "OnWalkable"])
    return state_message(pack_state(mover_id, 3, result, []))


def _error(kind: str, **details: Any) -> bytes:
    return msgpack.packb({"v": 1, "error": {"kind": kind, "message": kind, **details}})


class _Session(SessionDouble):
    """A zenoh.Session's `get` for a client: `answer(key, payload, asked_before)` says the replies; every
    request is recorded."""

    def __init__(self, answer: Callable[[str, bytes, int], list[_Reply]]) -> None:
        super().__init__()
        self.answer = answer
        self.sent: list[str] = []
        self.payloads: list[bytes] = []

    def get(self, key: Any, *, payload: bytes, timeout: float, **_options: Any) -> Any:
        key = str(key)
        asked_before = self.sent.count(key)
        self.sent.append(key)
        self.payloads.append(payload)
        return iter(self.answer(key, payload, asked_before))


def _client(answer: Callable[[str, bytes, int], list[_Reply]], *, located: bool = True,
            settled: bool = True) -> tuple[Client, _Session]:
    session = _Session(answer)
    client = Client(session=session)  # type: ignore[arg-type]
    if settled:
        client._opened -= 1.0  # older than SETTLE_S: a NoServiceError is not asked again
    if located:
        client.locate(7, 0xA9B4)
    return client, session


def test_the_usual_move_is_asked_once_and_learns_the_landblock() -> None:
    client, session = _client(lambda _k, _p, _n: [_Reply(ok=_state(0xA9B5))])
    st = client.move(7, offset=(0.2, 0.0, 0.0))
    assert session.sent == [HERE] and st.landblock == 0xA9B5 and client.known_landblocks[7] == 0xA9B5
    assert session.payloads == [pack_request({"move": {"id": 7, "offset": [0.2, 0.0, 0.0]}})]
    client.step(7, (0.0, 0.8, 0.0), 0.2)  # the next goes where the State said
    assert session.sent == [HERE, THERE]


def test_an_unseen_mover_is_found_first() -> None:
    def answer(key: str, _payload: bytes, _n: int) -> list[_Reply]:
        if key == "acphys/lb/*/get":
            return [_Reply(ok=_state(0xA9B5))]
        return [_Reply(ok=_state(0xA9B5))] if key == THERE else [_Reply(err=_error("moved", landblock=0xA9B5))]

    client, session = _client(answer, located=False)
    st = client.move(7, offset=(0.2, 0.0, 0.0))
    assert session.sent == ["acphys/lb/*/get", THERE] and st.landblock == 0xA9B5


@pytest.mark.parametrize("kind", ["moved", "wrong_landblock"])
def test_a_redirect_is_followed_with_the_same_bytes_and_each_key_asked_once(kind: str) -> None:
    def answer(key: str, _payload: bytes, _n: int) -> list[_Reply]:
        return [_Reply(ok=_state(0xA9B5))] if key == THERE else [_Reply(err=_error(kind, landblock=0xA9B5))]

    client, session = _client(answer)
    st = client.move(7, offset=(0.2, 0.0, 0.0), tag="t")
    assert session.sent == [HERE, THERE] and session.payloads[0] == session.payloads[1]
    assert st.landblock == 0xA9B5 and client.known_landblocks[7] == 0xA9B5


def test_redirects_end_after_the_last_one_allowed() -> None:
    hops = [0xA9B5, 0xA9B6, 0xA9B7, 0xA9B8, 0xA9B9, 0xA9BA]

    def answer(key: str, _payload: bytes, _n: int) -> list[_Reply]:
        lb = int(key.split("/")[2], 16)
        return [_Reply(err=_error("moved", landblock=hops[hops.index(lb) + 1] if lb in hops else hops[0]))]

    client, session = _client(answer)
    with pytest.raises(ServiceError) as e:
        client.move(7, offset=(0.2, 0.0, 0.0))
    # the first ask and four redirects followed (MAX_REDIRECTS); the fifth answer stands
    assert e.value.kind == "moved" and len(session.sent) == 5 and len(set(session.sent)) == 5


def test_a_redirect_to_the_same_landblock_raises() -> None:
    client, session = _client(lambda _k, _p, _n: [_Reply(err=_error("wrong_landblock", landblock=0xA9B4))])
    with pytest.raises(ServiceError, match="wrong_landblock"):
        client.move(7, offset=(0.2, 0.0, 0.0))
    assert session.sent == [HERE]


def test_nobody_answering_a_young_client_is_asked_again_once_settled() -> None:
    client, session = _client(lambda _k, _p, n: [_Reply(ok=_state())] if n else [], settled=False)
    assert client.move(7, offset=(0.2, 0.0, 0.0)).landblock == 0xA9B4
    assert session.sent == [HERE, HERE] and session.payloads[0] == session.payloads[1]

    client, session = _client(lambda _k, _p, _n: [], settled=False)
    with pytest.raises(NoServiceError, match=f"no service answers on {HERE}"):
        client.move(7, offset=(0.2, 0.0, 0.0))
    assert session.sent == [HERE, HERE]

    client, session = _client(lambda _k, _p, _n: [])  # settled: asked once
    with pytest.raises(NoServiceError):
        client.move(7, offset=(0.2, 0.0, 0.0))
    assert session.sent == [HERE]


def test_error_and_timeout_replies_raise_as_the_general_routine_raises_them() -> None:
    client, session = _client(lambda _k, _p, _n: [_Reply(err=_error("unknown_mover", path="move.id"))])
    with pytest.raises(ServiceError) as e:
        client.move(7, offset=(0.2, 0.0, 0.0))
    assert (e.value.kind, e.value.path, session.sent) == ("unknown_mover", "move.id", [HERE])

    client, session = _client(lambda _k, _p, _n: [_Reply(err=b"Timeout")])
    with pytest.raises(RequestTimeout, match=f"no answer on {HERE} within 5.0 s"):
        client.move(7, offset=(0.2, 0.0, 0.0))
    assert session.sent == [HERE]

    client, _ = _client(lambda _k, _p, _n: [_Reply(err=b"\xc1 garbled")])
    with pytest.raises(ServiceError, match="malformed: unreadable error reply"):
        client.step(7, (0.0, 0.8, 0.0), 0.2)


def test_a_state_in_another_shape_is_read_by_the_state_reader() -> None:
    usual = msgpack.unpackb(_state(0xA9B5))
    usual["state"]["extra"] = 1  # a key the short path does not know; the general reader ignores it
    client, session = _client(lambda _k, _p, _n: [_Reply(ok=msgpack.packb(usual))])
    st = client.move(7, offset=(0.2, 0.0, 0.0))
    assert type(st) is MoverState and st.landblock == 0xA9B5 and st.seq == 3 and session.sent == [HERE]
    assert client.known_landblocks[7] == 0xA9B5


def test_first_replies_answers_once_then_asks() -> None:
    asked: list[tuple[str, bytes, float]] = []

    def get(key: Any, payload: bytes, seconds: float) -> str:
        asked.append((key, payload, seconds))
        return "asked"

    first = FirstReplies([_Reply(ok=msgpack.packb({"v": 1, "x": 2}))], get, "here", True)
    assert first(HERE, b"p", 1.0) == {"v": 1, "x": 2} and asked == []
    assert first(THERE, b"p", 2.0) == "asked" and asked == [(THERE, b"p", 2.0)]


def test_gather_state_gives_the_replies_of_anything_but_a_state() -> None:
    session = _Session(lambda _k, _p, _n: [_Reply(ok=_state())])
    st = gather_state(session, HERE, b"p", 1.0)  # type: ignore[arg-type]
    assert type(st) is MoverState and st.id == 7
    replies = [_Reply(err=_error("busy"))]
    assert gather_state(_Session(lambda _k, _p, _n: replies), HERE, b"p", 1.0) == replies  # type: ignore[arg-type]
    assert gather_state(_Session(lambda _k, _p, _n: []), HERE, b"p", 1.0) == []  # type: ignore[arg-type]


def test_a_state_is_returned_without_waiting_for_the_querys_end() -> None:
    """The first reply a State: the replies are not read on (Zenoh's iterator would wait there for the
    query's final message); anything else: every reply, read to the end."""
    read_on: list[bool] = []

    class _Replies(SessionDouble):
        """A `get` whose replies after the first are read only on demand, and noted when they are."""

        def __init__(self, first: _Reply, rest: list[_Reply]) -> None:
            super().__init__()
            self.first, self.rest = first, rest

        def get(self, key: Any, *, payload: bytes, timeout: float, **_options: Any) -> Iterator[_Reply]:
            yield self.first
            read_on.append(True)
            yield from self.rest

    st = gather_state(_Replies(_Reply(ok=_state()), []), HERE, b"p", 1.0)  # type: ignore[arg-type]
    assert type(st) is MoverState and st.id == 7 and read_on == []
    busy, late = _Reply(err=_error("busy")), _Reply(ok=_state())
    assert gather_state(_Replies(busy, [late]), HERE, b"p", 1.0) == [busy, late]  # type: ignore[arg-type]
    assert read_on == [True]
