"""The State's packed bytes against an independent writer of docs/protocol.md's State map.

pack_state's bytes are compared byte for byte with the map written here by hand, field by field in the
order the service writes them, every value by msgpack.packb itself except the unsigned integers the
service writes at fixed width (ids and seq as uint64 `cf`, cells as uint32 `ce`, the landblock as uint16
`cd`: msgpack allows any width for a value). Nothing of the code under test is used to make the expected
bytes.
"""

from __future__ import annotations

from typing import Any

import msgpack
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.geometry import Plane, Position, Quat, Vec3
from engine.world.types import MoveResult
from service.protocol.codec import pack_state


def _packb(value: Any) -> bytes:
    return bytes(msgpack.packb(value, use_bin_type=True))


def _uint(code: int, width: int, value: int) -> bytes:
    return bytes((code,)) + value.to_bytes(width, "big")


def _u64(value: int) -> bytes:
    return _uint(0xCF, 8, value)


def _u32(value: int) -> bytes:
    return _uint(0xCE, 4, value)


def _map(entries: list[tuple[str, bytes]]) -> bytes:
    header = bytes(msgpack.Packer().pack_map_header(len(entries)))
    return header + b"".join(_packb(k) + v for k, v in entries)


def _vector(v: Vec3 | None) -> bytes:
    return _packb(None if v is None else [v.x, v.y, v.z])


def _expected(mover_id: int, seq: int, r: MoveResult, collide_ids: list[int], tag: Any) -> bytes:
    p = r.position
    q = p.frame.orientation
    position = _map([("cell", _u32(p.cell_id)), ("origin", _vector(p.frame.origin)),
                     ("orientation", _packb([q.w, q.x, q.y, q.z]))])
    plane = _packb(None) if r.contact_plane is None else _map(
        [("normal", _vector(r.contact_plane.normal)), ("d", _packb(r.contact_plane.d))])
    entries = [
        ("id", _u64(mover_id)), ("seq", _u64(seq)), ("ok", _packb(r.ok)), ("position", position),
        ("landblock", _uint(0xCD, 2, p.cell_id >> 16)), ("transition_state", _packb(r.transition_state)),
        ("contact", _packb(r.contact)), ("on_walkable", _packb(r.on_walkable)), ("contact_plane", plane),
        ("contact_plane_cell", _packb(None) if r.contact_plane_cell is None else _u32(r.contact_plane_cell)),
        ("collision_normal", _vector(r.collision_normal)), ("sliding_normal", _vector(r.sliding_normal)),
        ("water_contact", _packb(r.water_contact)), ("frames_stationary_fall", _packb(r.frames_stationary_fall)),
        ("transient_state", _packb(list(r.transient_state))), ("collide_objects", _packb(collide_ids)),
    ]
    if tag is not None:  # the tag, when given, comes last
        entries.append(("tag", _packb(tag)))
    return _map(entries)


# the edges of every msgpack integer width
uint64s = st.sampled_from([0, 1, 127, 128, 255, 256, 65535, 65536, (1 << 32) - 1, 1 << 32, (1 << 64) - 1]) | st.integers(
    0, (1 << 64) - 1)
uint32s = st.integers(0, (1 << 32) - 1)
reals = st.floats(allow_nan=False, allow_infinity=False)
vec3s = st.builds(Vec3, reals, reals, reals)
FLAGS = ["Contact", "OnWalkable", "Sliding", "WaterContact", "StationaryFall", "StationaryStop", "StationaryStuck"]
results = st.builds(
    MoveResult, st.booleans(),
    st.builds(Position.at, uint32s, vec3s, st.builds(Quat, reals, reals, reals, reals)),
    # arbitrary text too: more distinct names than the packer keeps packed
    st.sampled_from(["OK", "Collided", "Adjusted", "Slid", "Invalid", "NoTransition"]) | st.text(max_size=40),
    st.booleans(), st.booleans(), st.none() | st.builds(Plane, vec3s, reals), st.none() | uint32s,
    st.none() | vec3s, st.none() | vec3s, st.booleans(),
    st.none() | st.integers(0, 3) | st.integers(-(1 << 63), (1 << 64) - 1),
    st.lists(st.sampled_from(FLAGS), max_size=7) | st.lists(st.text(max_size=12), max_size=3), st.just([]),
)
tags = st.none() | st.integers(-(1 << 63), (1 << 64) - 1) | st.text(max_size=256)


@settings(max_examples=500, deadline=None)
@given(mover_id=uint64s, seq=uint64s, r=results, collide_ids=st.lists(uint64s, max_size=20), tag=tags)
def test_packed_state_is_the_documented_map_byte_for_byte(mover_id: int, seq: int, r: MoveResult,
                                                          collide_ids: list[int], tag: Any) -> None:
    assert pack_state(mover_id, seq, r, collide_ids, tag) == _expected(mover_id, seq, r, collide_ids, tag)


def test_a_known_state_byte_for_byte() -> None:
    """One State written out by hand from its bytes' description, as a check of the writer above."""
    r = MoveResult(True, Position.at(0xA9B40001, Vec3(1.0, 2.0, 3.0), Quat()), "OK", True, True, None, None, None,
                   None, False, 0, [], [])
    b = pack_state(7, 1, r, [])
    assert b == _expected(7, 1, r, [], None)
    assert b[:3] == b"\xde\x00\x10"  # map16: 16 entries
    assert b[3:15] == b"\xa2id\xcf\x00\x00\x00\x00\x00\x00\x00\x07"
    landblock = b.index(b"\xa9landblock")
    assert b[landblock + 10:landblock + 13] == b"\xcd\xa9\xb4"
    assert b.endswith(b"\xb6frames_stationary_fall\x00\xaftransient_state\x90\xafcollide_objects\x90")
