"""A one-move request read straight from its bytes (move_structs.plain_single_move) agrees with the
request map's path it stands in front of (requests.decode_envelope, then parse_single_move).

The bytes reader may only answer for a request the map's path accepts, with the same MoveItem and the
same `publish` mode; for everything else (a fault, a batch, a column request, a field it does not name)
it answers None and the map's path runs, so every error stays that path's.
"""

from __future__ import annotations

from typing import Any

import msgpack
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from service.protocol.errors import ProtocolError
from service.protocol.move_structs import plain_single_move
from service.protocol.requests import decode_envelope, parse_single_move

CELL = 0xA9B40001


def _map_path(payload: bytes) -> Any:
    """What the node's map path makes of a move request: ("single", item, batch), ("other",) for a request
    that is not a plain single move, or the error's (kind, path, message)."""
    try:
        msg = decode_envelope(payload)
        if "move" not in msg or "moves" in msg or msg.get("columns") is not None:
            return ("other",)
        item, batch = parse_single_move(msg)
        return ("single", item, batch)
    except ProtocolError as e:
        return ("error", e.kind, e.path, e.message)


def _agrees(payload: bytes) -> bool:
    """The bytes reader answers None, or exactly what the map's path gives; True when it answered."""
    fast = plain_single_move(payload)
    if fast is None:
        return False
    assert _map_path(payload) == ("single", *fast)
    return True


SENT = [
    {"v": 1, "move": {"id": 7, "offset": [0.2, 0.0, 0.0]}},
    {"v": 1, "move": {"id": 7, "offset": [1, 2, 3]}},  # integers for reals, as msgpack may send them
    {"v": 1, "move": {"id": (1 << 64) - 1, "offset": [0.0, 0.0, 0.0], "tag": "w-3"}, "publish": "each"},
    {"v": 1, "move": {"id": 7, "offset": [0.5, 0.0, 0.0], "velocity": [1.0, 0.0, -9.8], "tag": -(1 << 63)}},
    {"v": 1, "move": {"id": 7, "to": {"origin": [10.0, 20.0, 30.0]}}, "publish": "batch"},
    {"v": 1, "move": {"id": 7, "to": {"cell": CELL, "origin": [10.0, 20.0, 30.0], "orientation": [0.0, 0.0, 0.0, 1.0]}}},
    {"v": 1, "move": {"id": 7, "motion": [1.0, 0.0, 0.0], "dt": 0.1, "tag": 9}},
    {"move": {"id": 7, "offset": [0.2, 0.0, 0.0]}, "v": 1, "publish": None},
]


@pytest.mark.parametrize("msg", SENT, ids=range(len(SENT)))
def test_a_plain_single_move_is_read_from_its_bytes_as_the_map_path_reads_it(msg: dict[str, Any]) -> None:
    assert _agrees(msgpack.packb(msg))


NOT_PLAIN = [
    {"v": 2, "move": {"id": 7, "offset": [0.2, 0.0, 0.0]}},  # unsupported version
    {"v": True, "move": {"id": 7, "offset": [0.2, 0.0, 0.0]}},
    {"v": 1, "move": None},  # missing
    {"v": 1, "move": {"id": 7, "offset": [0.2, 0.0, 0.0]}, "moves": [{"id": 7, "offset": [0.2, 0.0, 0.0]}]},
    {"v": 1, "move": {"id": 7, "offset": [0.2, 0.0, 0.0]}, "columns": {"id": b""}},
    {"v": 1, "move": {"id": 7, "offset": [0.2, 0.0, 0.0]}, "extra": 1},  # the map's path takes it: ignored field
    {"v": 1, "move": {"id": 7, "offset": [0.2, 0.0, 0.0], "other": 1}},
    {"v": 1, "move": {"id": 7, "to": {"origin": [1.0, 2.0, 3.0], "other": 1}}},
    {"v": 1, "move": {"id": 7, "offset": [0.2, 0.0, 0.0]}, "publish": "all"},
    {"v": 1, "move": {"id": 7, "offset": [0.2, 0.0, 0.0], "to": {"origin": [1.0, 2.0, 3.0]}}},
    {"v": 1, "move": {"id": 7, "to": {"origin": [1.0, 2.0, 3.0], "orientation": [1.0, 1.0, 0.0, 0.0]}}},
    {"v": 1, "move": {"id": 7, "motion": [1.0, 0.0, 0.0]}},  # dt missing
    {"v": 1, "move": {"id": 7, "offset": [float("nan"), 0.0, 0.0]}},
    {"v": 1, "move": {"id": -1, "offset": [0.2, 0.0, 0.0]}},
    {1: 1, "v": 1, "move": {"id": 7, "offset": [0.2, 0.0, 0.0]}},  # a key that is not a string
]


@pytest.mark.parametrize("msg", NOT_PLAIN, ids=range(len(NOT_PLAIN)))
def test_anything_else_is_left_to_the_map_path(msg: dict[str, Any]) -> None:
    assert plain_single_move(msgpack.packb(msg)) is None


@pytest.mark.parametrize("payload", [b"", b"\xc1", b"\x93\x01\x02\x03", msgpack.packb(SENT[0]) + b"\x00",
                                     msgpack.packb(SENT[0])[:-3]])
def test_bytes_that_are_not_one_map_are_left_to_the_map_path(payload: bytes) -> None:
    assert plain_single_move(payload) is None


numbers = st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=64), st.integers(-3, 3), st.booleans(),
                    st.none())
vectors = st.one_of(st.lists(numbers, min_size=2, max_size=5), numbers, st.text(max_size=2))
moves = st.dictionaries(
    st.sampled_from(["id", "offset", "to", "velocity", "tag", "motion", "dt", "other"]),
    st.one_of(vectors, st.integers(-2, (1 << 64) - 1), st.text(max_size=3),
              st.fixed_dictionaries({"origin": vectors},
                                    optional={"cell": st.integers(-1, 1 << 33), "orientation": vectors})),
)
requests = st.fixed_dictionaries(
    {"move": st.one_of(moves, st.none(), st.integers(0, 3))},
    optional={"v": st.sampled_from([1, 1, 1, 2, True, None, 1.0]), "publish": st.sampled_from(["each", "batch", "x", 3]),
              "moves": st.just([]), "tag": st.integers(0, 3)},
)


@settings(max_examples=600, deadline=None)
@given(msg=requests)
def test_any_request_reads_the_same_or_goes_to_the_map_path(msg: dict[str, Any]) -> None:
    _agrees(msgpack.packb(msg))


def test_duplicate_keys_read_as_the_map_path_reads_them() -> None:
    """msgpack keeps the last of two equal keys; so must the bytes reader (or leave it to the map path)."""
    first, last = {"id": 7, "offset": [0.2, 0.0, 0.0]}, {"id": 8, "offset": [0.0, 0.5, 0.0]}
    payload = (b"\x83" + msgpack.packb("v") + msgpack.packb(1) + msgpack.packb("move") + msgpack.packb(first)
               + msgpack.packb("move") + msgpack.packb(last))
    fast = plain_single_move(payload)
    assert fast is None or fast[0].id == 8
    _agrees(payload)
