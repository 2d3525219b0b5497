"""The single move's path through the client library without a service: the request bytes `Client.move` and
`Client.step` put on the wire, and the State reply read straight from its bytes (clients/state_reply.py)
against the usual reading (msgpack, then MoverState.from_wire)."""

from __future__ import annotations

import decimal
import math
import uuid
from collections.abc import Callable
from typing import Any

import msgpack
import pytest

from clients import Client, Move, ServiceError
from clients.errors import NoServiceError
from clients.request_channel import pack_move_request, pack_request, unpack_message
from clients.state_reply import decode_state_reply
from clients.types import MoverState
from engine import MoveResult
from engine.geometry import Plane, Position, Quat, Vec3
from service.protocol.codec import pack_state
from service.protocol.errors import ProtocolError
from service.protocol.frames import state_message
from support.service_harness import StandInReply as _Reply
from support.sessions import SessionDouble

CELL = 0xA9B40001


def _result(**changes: Any) -> MoveResult:
    values: dict[str, Any] = dict(
        ok=True, position=Position.at(CELL, Vec3(20.0, 20.0, 50.0)), transition_state="OK", contact=True,
        on_walkable=True, contact_plane=None, contact_plane_cell=CELL, collision_normal=None, sliding_normal=None,
        water_contact=False, frames_stationary_fall=0, transient_state=["Contact", "OnWalkable"])
    values.update(changes)
    return MoveResult(**values)


#: States as the service packs them, in the shapes a move's reply takes
RESULTS = [
    (7, 1, _result(), [], None),
    (2**64 - 1, 2**40, _result(ok=False, transition_state="Collided"), [5, 2**63], "a tag ✓"),
    (9, 3, _result(position=Position.at(0x01020103, Vec3(-1.5, 191.9, -3.0e3), Quat(0.6, 0.0, 0.0, 0.8)),
                   contact_plane=Plane(Vec3(0.0, 0.6, 0.8), -12.25), collision_normal=Vec3(1.0, 0.0, 0.0),
                   sliding_normal=Vec3(0.0, -1.0, 0.0), water_contact=True, frames_stationary_fall=None,
                   transient_state=[]), [1], -(2**63)),
    (10, 0, _result(contact=False, on_walkable=False, contact_plane_cell=None), [], 2**64 - 1),
]


def _usual(payload: bytes) -> MoverState:
    """The reply read the usual way: msgpack, then the State's reader."""
    return MoverState.from_wire(unpack_message(payload)["state"])


def _same(a: MoverState, b: MoverState) -> bool:
    """Equal field for field, with the same types (repr tells 1 from 1.0)."""
    return repr(a) == repr(b) and type(a.result.position.origin.x) is type(b.result.position.origin.x)


@pytest.mark.parametrize("mover_id, seq, result, collide, tag", RESULTS)
def test_a_state_reply_reads_as_the_usual_reader_reads_it(mover_id: int, seq: int, result: MoveResult,
                                                          collide: list[int], tag: Any) -> None:
    payload = state_message(pack_state(mover_id, seq, result, collide, tag))
    st = decode_state_reply(payload)
    assert st is not None and _same(st, _usual(payload))
    assert (st.id, st.seq, st.tag, st.result.collide_objects) == (mover_id, seq, tag, collide)
    assert st.position.cell_id == result.position.cell_id and st.landblock == result.position.cell_id >> 16
    assert st.contact_plane == result.contact_plane and st.result.sliding_normal == result.sliding_normal


def _state_map(**changes: Any) -> dict[str, Any]:
    m: dict[str, Any] = unpack_message(state_message(pack_state(7, 1, _result(), [], None)))
    m["state"].update(changes)
    return m


def _without(key: str) -> dict[str, Any]:
    m = _state_map()
    del m["state"][key]
    return m


#: replies left to the usual reader: not a State, or a State in a shape the service does not write
OTHER_SHAPES: list[Any] = [
    {"v": 1, "error": {"kind": "unknown_mover", "message": "no such mover"}},
    {"v": 1},
    [1, 2],
    _state_map(extra=1),
    _state_map(position={"cell": CELL, "origin": [1.0, 2.0, 3.0]}),  # orientation left to its default
    _state_map(position={"cell": CELL, "origin": [math.nan, 2.0, 3.0], "orientation": [1.0, 0.0, 0.0, 0.0]}),
    _state_map(position={"cell": CELL, "origin": [1e39, 2.0, 3.0], "orientation": [1.0, 0.0, 0.0, 0.0]}),
    _state_map(position={"cell": 2**32, "origin": [1.0, 2.0, 3.0], "orientation": [1.0, 0.0, 0.0, 0.0]}),
    _state_map(position={"cell": CELL, "origin": [1.0, 2.0, 3.0], "orientation": [0.9, 0.0, 0.0, 0.0]}),
    _state_map(contact_plane={"normal": [0.0, 0.0, 0.9], "d": 1.0}),
    _state_map(id=-1),
    _state_map(seq=1.0),
    _state_map(tag="x" * 257),
    _state_map(tag=1.5),
    _state_map(water_contact=None),
    _state_map(transient_state=None),
    _state_map(collide_objects=[-1]),
    _state_map(ok=1),
    _without("contact"),
    _state_map(state="nothing"),
]
#: States in shapes the service does not write that read the same either way
LIKE_SHAPES: list[Any] = [
    _state_map(position={"cell": CELL, "origin": [1, 2, 3], "orientation": [1.0, 0.0, 0.0, 0.0]}),
    _without("landblock"),
]


@pytest.mark.parametrize("reply", LIKE_SHAPES)
def test_a_state_in_a_like_shape_reads_the_same(reply: Any) -> None:
    payload = msgpack.packb(reply, use_bin_type=True)
    st = decode_state_reply(payload)
    assert st is not None and _same(st, _usual(payload))


@pytest.mark.parametrize("reply", OTHER_SHAPES)
def test_any_other_reply_is_left_to_the_usual_reader(reply: Any) -> None:
    payload = msgpack.packb(reply, use_bin_type=True)
    assert decode_state_reply(payload) is None
    assert decode_state_reply(payload + b"\x00") is None


class _Session(SessionDouble):
    """What a Client uses of a zenoh.Session for one request: `get`, answered by `answer(key, payload)`."""

    def __init__(self, answer: Callable[[str, bytes], list[_Reply]]) -> None:
        super().__init__()
        self.answer = answer
        self.sent: list[tuple[str, bytes]] = []

    def get(self, key: Any, *, payload: bytes, timeout: float) -> Any:
        self.sent.append((str(key), payload))
        return iter(self.answer(str(key), payload))


def _client(answer: Callable[[str, bytes], list[_Reply]]) -> tuple[Client, _Session]:
    session = _Session(answer)
    client = Client(session=session)  # type: ignore[arg-type]
    client.locate(7, CELL >> 16)
    client.locate(9, CELL >> 16)
    return client, session


MOVES = [
    Move(7, offset=(0.2, 0, 0)),
    Move(7, offset=Vec3(1.0, 2.0, 3.0), velocity=(1, 2, 3), tag="walk"),
    Move(7, to=Position.at(CELL, Vec3(1.0, 2.0, 3.0), Quat(0.6, 0.0, 0.0, 0.8)), tag=-5),
    Move(7, to=Position.at(CELL, Vec3(1.0, 2.0, 3.0)), keep_cell=False, tag=2**64 - 1),
    Move(9, motion=(0.0, 0.8, 0.0), dt=0.2, tag=300),
]


@pytest.mark.parametrize("move", MOVES)
def test_a_move_request_is_packed_as_any_request(move: Move) -> None:
    assert pack_move_request(move.to_wire()) == pack_request({"move": move.to_wire()})


#: every msgpack integer and string form, floats of every kind, and the subclasses msgpack packs as their base
_INTS = [0, 1, 127, 128, 255, 256, 65535, 65536, 2**32 - 1, 2**32, 2**63, 2**64 - 1,
         -1, -32, -33, -128, -129, -32768, -32769, -(2**31), -(2**31) - 1, -(2**63)]
_STRS = ["", "a" * 31, "a" * 32, "é" * 127, "b" * 256, "✓" * 100]
_FLOATS = [0.0, -0.0, 0.2, 1e-310, 3.4e38, 1e300, math.inf, -math.inf, math.nan]


class _Tag(str):
    pass


class _Count(int):
    pass


@pytest.mark.parametrize("tag", [None, True, _Tag("sub"), _Count(3), *_INTS, *_STRS])
def test_every_tag_and_id_packs_as_any_request(tag: Any) -> None:
    for mover_id in (tag if type(tag) is int and tag >= 0 else 7, _Count(9)):
        wire = Move(mover_id, offset=(0.2, 0, 0), tag=tag).to_wire()
        assert pack_move_request(wire) == pack_request({"move": wire})


@pytest.mark.parametrize("x", [*_FLOATS, *_INTS])
def test_every_number_packs_as_any_request(x: Any) -> None:
    for move in (Move(7, offset=(x, 0.0, 1.0)), Move(7, motion=Vec3(x, x, x), dt=x),
                 Move(7, to=Position.at(CELL, Vec3(x, 0.0, 0.0), Quat(x, 0.0, 0.0, 0.0)), velocity=(x, x, x)),
                 Move(7, motion=(0.0, 0.8, 0.0), dt=0.25)):
        wire = move.to_wire()
        packed = pack_move_request(wire)
        assert packed == pack_request({"move": wire})
        assert packed == msgpack.packb({"v": 1, "move": wire}, use_bin_type=True)


@pytest.mark.parametrize("tag", [object(), uuid.UUID(int=5), decimal.Decimal("0.5"), {1, 2}, 2**64])
def test_a_move_that_cannot_be_packed_fails_as_before(tag: Any) -> None:
    """Values msgpack refuses (some of which msgspec would pack) raise msgpack's error, as any request's."""
    wire = Move(7, offset=(0.2, 0, 0), tag=tag).to_wire()
    with pytest.raises((TypeError, OverflowError)) as usual:
        pack_request({"move": wire})
    with pytest.raises(type(usual.value)):
        pack_move_request(wire)
    wire = Move(7, motion=(0.0, 0.8, 0.0), dt=tag).to_wire()
    with pytest.raises(type(usual.value)):
        pack_move_request(wire)


def test_move_and_step_send_the_request_and_return_the_state() -> None:
    reply = state_message(pack_state(7, 4, _result(), [], "t"))
    client, session = _client(lambda _key, _payload: [_Reply(ok=reply)])
    st = client.move(7, offset=(0.2, 0.0, 0.0), tag="t")
    assert _same(st, _usual(reply))
    st = client.step(7, (0.0, 0.8, 0.0), 0.2)
    assert _same(st, _usual(reply))
    assert session.sent == [
        (f"acphys/lb/{CELL >> 16:04X}/move", pack_request({"move": {"id": 7, "tag": "t", "offset": [0.2, 0.0, 0.0]}})),
        (f"acphys/lb/{CELL >> 16:04X}/move", pack_request({"move": {"id": 7, "motion": [0.0, 0.8, 0.0], "dt": 0.2}}))]


@pytest.mark.parametrize("reply", [OTHER_SHAPES[1]] + OTHER_SHAPES[3:] + LIKE_SHAPES)
def test_a_state_in_another_shape_reads_as_the_usual_reader_reads_it(reply: Any) -> None:
    payload = msgpack.packb(reply, use_bin_type=True)
    client, _ = _client(lambda _key, _payload: [_Reply(ok=payload)])
    try:
        expected: MoverState | Exception = _usual(payload)
    except (ProtocolError, KeyError, TypeError) as e:
        expected = e
    if isinstance(expected, Exception):
        with pytest.raises(type(expected)) as got:
            client.move(7, offset=(0.2, 0.0, 0.0))
        assert str(got.value) == str(expected)
    else:
        assert _same(client.move(7, offset=(0.2, 0.0, 0.0)), expected)


def test_an_error_reply_raises_and_a_redirect_is_followed() -> None:
    moved = msgpack.packb({"v": 1, "error": {"kind": "moved", "message": "handed over", "landblock": 0xA9B5}})
    state = state_message(pack_state(7, 2, _result(position=Position.at(0xA9B50001, Vec3(1.0, 2.0, 3.0))), []))

    def answer(key: str, _payload: bytes) -> list[_Reply]:
        return [_Reply(err=moved)] if key.endswith("A9B4/move") else [_Reply(ok=state)]

    client, session = _client(answer)
    st = client.move(7, offset=(0.2, 0.0, 0.0))
    assert [k for k, _ in session.sent] == ["acphys/lb/A9B4/move", "acphys/lb/A9B5/move"]
    assert session.sent[0][1] == session.sent[1][1]
    assert st.landblock == 0xA9B5 and client.known_landblocks[7] == 0xA9B5

    unknown = msgpack.packb({"v": 1, "error": {"kind": "unknown_mover", "message": "no mover 9", "path": "move.id"}})
    client, _ = _client(lambda _key, _payload: [_Reply(err=unknown)])
    with pytest.raises(ServiceError) as e:
        client.move(9, offset=(0.2, 0.0, 0.0))
    assert (e.value.kind, e.value.path) == ("unknown_mover", "move.id")

    not_a_map = msgpack.packb([1, 2])
    client, _ = _client(lambda _key, _payload: [_Reply(ok=not_a_map)])
    with pytest.raises(ServiceError, match="malformed: unreadable reply on acphys/lb/A9B4/move"):
        client.move(7, offset=(0.2, 0.0, 0.0))

    client, _ = _client(lambda _key, _payload: [])
    client._opened -= 1.0  # settled: no second ask
    with pytest.raises(NoServiceError, match="no service answers on acphys/lb/A9B4/move"):
        client.move(7, offset=(0.2, 0.0, 0.0))
