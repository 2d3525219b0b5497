"""The service's fast paths agree with the per-field readers they stand in for.

Moves and States of the usual shape are read without the per-field readers
(service.protocol.requests._plain_move, service.protocol.codec._plain_state: the fast readers
service/protocol/schema.py generates from the MOVE and STATE declarations) and whole
messages are put together from packed States (service.protocol.frames). Each must
give exactly what the slow path gives, and must never accept what the slow
path refuses: whatever the fast path cannot vouch for goes to the slow path,
which names the offending field.
"""

from __future__ import annotations

import copy
import math
from typing import Any

import msgpack
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from engine.geometry import Plane, Position, Quat, Vec3
from engine.world.types import MoveResult
from service.protocol.codec import _plain_state, decode_state, encode_state, pack_state, read_state
from service.protocol.errors import ProtocolError
from service.protocol.frames import array_header, results_message, state_message
from service.bus.jobqueue import JobQueue
from service.protocol.requests import _plain_move, parse_move_item, parse_moves, read_move_item

CELL = 0xA9B40001
HALF_TURN_Z = [0.0, 0.0, 0.0, 1.0]  # 180 degrees about z: a unit quaternion


def _outcome(fn: Any, value: Any, path: str) -> Any:
    """What `fn` gives: its value, or the error's (kind, path, message)."""
    try:
        return ("ok", fn(value, path))
    except ProtocolError as e:
        return ("error", e.kind, e.path, e.message)


# -- moves ------------------------------------------------------------------------------------------
VALID_MOVES: list[dict[str, Any]] = [
    {"id": 7, "offset": [0.5, 0.0, -0.25]},
    {"id": 7, "offset": [0.5, 0.0, 0.0], "tag": 3},
    {"id": (1 << 64) - 1, "offset": [0.0, 0.0, 0.0], "tag": "w-3"},
    {"id": 7, "offset": [0.5, 0.0, 0.0], "velocity": [1.0, 0.0, -9.8], "tag": -(1 << 63)},
    {"id": 7, "to": {"origin": [10.0, 20.0, 30.0]}},
    {"id": 7, "to": {"cell": CELL, "origin": [10.0, 20.0, 30.0]}, "tag": "x" * 256},
    {"id": 7, "to": {"cell": CELL, "origin": [10.0, 20.0, 30.0], "orientation": HALF_TURN_Z}},
    {"id": 7, "to": {"origin": [1.0, 2.0, 3.0], "orientation": [0.7071068, 0.0, 0.0, 0.7071068]},
     "velocity": [0.0, 0.0, 0.0]},
]


@pytest.mark.parametrize("move", VALID_MOVES, ids=range(len(VALID_MOVES)))
def test_usual_moves_take_the_fast_path_and_read_the_same(move: dict[str, Any]) -> None:
    fast = _plain_move(move, "moves[4]")
    assert fast is not None  # the fast path is really used for these
    assert fast == read_move_item(move, "moves[4]")
    assert fast.path == "moves[4]" and fast.id == move["id"] and fast.tag == move.get("tag")


def test_fast_move_values() -> None:
    item = parse_move_item({"id": 9, "to": {"origin": [1.0, 2.0, 3.0], "orientation": HALF_TURN_Z}}, "move")
    assert item.to is not None and item.to.cell is None  # the mover's own cell, resolved later
    assert item.to.origin == Vec3(1.0, 2.0, 3.0) and item.to.orientation == Quat(0.0, 0.0, 0.0, 1.0)
    assert item.offset is None and item.motion is None and item.velocity is None


# Each turns a valid move into one the fast path must hand over: refused ones, or accepted only by the
# full reader (ints for floats, unknown keys), or shapes it does not cover (motion + dt).
MUTATIONS: list[tuple[str, Any, str | None]] = [
    ("offset", [math.nan, 0.0, 0.0], "non_finite"),
    ("offset", [0.0, math.inf, 0.0], "non_finite"),
    ("offset", [0.0, 0.0, -math.inf], "non_finite"),
    ("offset", [1e308, 1e308, 0.0], "bad_value"),  # finite, but beyond single precision
    ("offset", [0.0, -3.5e38, 0.0], "bad_value"),  # just beyond the largest float32
    ("offset", [3.4e38, 0.0, 0.0], None),  # a float32: read here, refused later as a target out of bounds
    ("velocity", [0.0, 0.0, 1e39], "bad_value"),
    ("offset", [1, 0, 0], None),  # integers are numbers too
    ("offset", [True, 0.0, 0.0], "wrong_type"),
    ("offset", [0.0, 0.0], "bad_value"),
    ("offset", [0.0, 0.0, 0.0, 0.0], "bad_value"),
    ("offset", "up", "wrong_type"),
    ("offset", (0.0, 0.0, 0.0), "wrong_type"),  # a tuple is not what msgpack gives for an array
    ("id", -1, "bad_value"),
    ("id", 1 << 64, "bad_value"),
    ("id", 7.0, "wrong_type"),
    ("id", True, "wrong_type"),
    ("id", None, "missing_field"),
    ("tag", True, "wrong_type"),
    ("tag", 1.5, "wrong_type"),
    ("tag", "x" * 257, "too_large"),
    ("tag", 1 << 64, "bad_value"),
    ("tag", -(1 << 63) - 1, "bad_value"),
    ("tag", None, None),
    ("velocity", [0.0, math.nan, 0.0], "non_finite"),
    ("velocity", [0.0, 0.0], "bad_value"),
    ("velocity", None, None),
    ("to", {"origin": [1.0, 2.0, 3.0]}, "bad_value"),  # with offset: both given
    ("motion", [1.0, 0.0, 0.0], "bad_value"),  # with offset: both given
    ("unknown_key", 1, None),  # ignored by the protocol
    (3, "non-string key", "wrong_type"),
]


@pytest.mark.parametrize("key,value,kind", MUTATIONS, ids=[f"{k}={v!r}"[:40] for k, v, _ in MUTATIONS])
def test_unusual_moves_are_read_by_the_full_reader(key: Any, value: Any, kind: str | None) -> None:
    move = {"id": 7, "offset": [0.5, 0.0, 0.0]}
    move[key] = value
    if value is None:
        del move[key]
        move[key] = None  # present but nil: the same as absent
    outcome = _outcome(parse_move_item, move, "moves[2]")
    assert outcome == _outcome(read_move_item, move, "moves[2]")
    if kind is None:
        assert outcome[0] == "ok"
    else:
        assert outcome[0] == "error" and outcome[1] == kind
        assert _plain_move(move, "moves[2]") is None


TO_MUTATIONS: list[tuple[str, Any, str | None]] = [
    ("orientation", [1.0, 0.0, 0.0, 0.01], "bad_value"),  # length 1.00005: within 1e-3, accepted
    ("orientation", [2.0, 0.0, 0.0, 0.0], "bad_value"),
    ("orientation", [math.nan, 0.0, 0.0, 0.0], "non_finite"),
    ("orientation", [1.0, 0.0, 0.0], "bad_value"),
    ("orientation", [1, 0, 0, 0], None),
    ("cell", 1 << 32, "bad_value"),
    ("cell", -1, "bad_value"),
    ("cell", "A9B40001", "wrong_type"),
    ("origin", [0.0, math.nan, 0.0], "non_finite"),
    ("origin", None, "missing_field"),
    ("extra", 0, None),
]


@pytest.mark.parametrize("key,value,kind", TO_MUTATIONS, ids=[f"{k}={v!r}"[:40] for k, v, _ in TO_MUTATIONS])
def test_unusual_targets_are_read_by_the_full_reader(key: str, value: Any, kind: str | None) -> None:
    move = {"id": 7, "to": {"cell": CELL, "origin": [1.0, 2.0, 3.0], "orientation": HALF_TURN_Z}}
    move["to"][key] = value
    if key == "orientation" and value == [1.0, 0.0, 0.0, 0.01]:
        kind = None  # |q| = 1.00005, inside the protocol's 1e-3
    outcome = _outcome(parse_move_item, move, "move")
    assert outcome == _outcome(read_move_item, move, "move")
    if kind is None:
        assert outcome[0] == "ok"
    else:
        assert outcome[0] == "error" and outcome[1] == kind


def test_a_bad_item_of_a_batch_names_its_own_field() -> None:
    b = parse_moves({"v": 1, "moves": [{"id": 1, "offset": [0.1, 0.0, 0.0]}, {"id": 2, "offset": [0.0, math.nan, 0.0]}]})
    assert not isinstance(b.items[0], type(b.items[1]))
    err = b.items[1]
    assert err.error.kind == "non_finite" and err.error.path == "moves[1].offset[1]"  # type: ignore[union-attr]


numbers = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-3, 3), st.booleans(), st.none())
vectors = st.one_of(st.lists(numbers, min_size=2, max_size=5), numbers, st.text(max_size=2))
fields = st.dictionaries(
    st.sampled_from(["id", "offset", "to", "velocity", "tag", "motion", "dt", "other"]),
    st.one_of(vectors, st.integers(-2, 1 << 65), st.text(max_size=3),
              st.fixed_dictionaries({"origin": vectors}, optional={"cell": st.integers(-1, 1 << 33), "orientation": vectors})),
)


@settings(max_examples=400, deadline=None)
@given(move=fields)
def test_any_move_reads_the_same_through_both_paths(move: dict[str, Any]) -> None:
    assert _outcome(parse_move_item, move, "moves[0]") == _outcome(read_move_item, move, "moves[0]")


# -- states -------------------------------------------------------------------------------------------
def _result(**kw: Any) -> MoveResult:
    base: dict[str, Any] = dict(
        ok=True, position=Position.at(CELL, Vec3(1.0, 2.0, 3.0), Quat(0.0, 0.0, 0.0, 1.0)),
        transition_state="Slid", contact=True, on_walkable=False, contact_plane=Plane(Vec3(0.0, 0.6, 0.8), -4.0),
        contact_plane_cell=CELL, collision_normal=Vec3(1.0, 0.0, 0.0), sliding_normal=Vec3(0.0, 1.0, 0.0),
        water_contact=True, frames_stationary_fall=2, transient_state=["Contact", "Sliding"], collide_objects=[5],
    )
    base.update(kw)
    return MoveResult(**base)


RESULTS = [
    _result(),
    _result(contact_plane=None, contact_plane_cell=None, collision_normal=None, sliding_normal=None,
            frames_stationary_fall=None, transient_state=[], collide_objects=[], water_contact=False),
    _result(ok=False, transition_state="NoTransition", position=Position.at(CELL, Vec3(0.0, 0.0, 0.0))),
]


def _wire(r: MoveResult, tag: Any = None) -> dict[str, Any]:
    return msgpack.unpackb(msgpack.packb(encode_state(11, 4, r, [9, 10], tag)), raw=False)


@pytest.mark.parametrize("index", range(len(RESULTS)))
def test_states_take_the_fast_path_and_read_the_same(index: int) -> None:
    wire = _wire(RESULTS[index], tag="t")
    fast = _plain_state(wire)
    assert fast is not None
    slow = read_state(wire)
    assert fast[:3] == slow[:3] == (11, 4, "t")
    assert encode_state(11, 4, fast[3], [9, 10], "t") == encode_state(11, 4, slow[3], [9, 10], "t") == wire
    assert fast[3].collide_objects == [9, 10]


STATE_MUTATIONS: list[tuple[tuple[str, ...], Any, bool]] = [
    (("position", "origin"), [0.0, math.nan, 0.0], False),
    (("position", "orientation"), [2.0, 0.0, 0.0, 0.0], False),
    (("position", "cell"), 1 << 32, False),
    (("contact_plane", "normal"), [0.0, 0.0, 2.0], False),
    (("contact_plane", "d"), math.inf, False),
    (("collision_normal",), [0.0, 0.0], False),
    (("id",), -1, False),
    (("seq",), "3", False),
    (("ok",), 1, False),
    (("transition_state",), None, False),
    (("contact_plane", "d"), 4, True),  # an integer is a number
    (("frames_stationary_fall",), 1.0, False),  # "int 0..3 or nil": a float is refused
    (("collide_objects",), [True], False),  # "array of uint64": a boolean is not one
    (("frames_stationary_fall",), 2, True),
    (("position", "orientation"), None, True),  # default: identity
]


@pytest.mark.parametrize("where,value,accepted", STATE_MUTATIONS, ids=[".".join(w) for w, _, _ in STATE_MUTATIONS])
def test_unusual_states_are_read_by_the_full_reader(where: tuple[str, ...], value: Any, accepted: bool) -> None:
    wire = copy.deepcopy(_wire(RESULTS[0]))
    target = wire
    for k in where[:-1]:
        target = target[k]
    target[where[-1]] = value
    outcomes = []
    for fn in (decode_state, read_state):
        try:
            mid, seq, tag, r = fn(wire)
            outcomes.append(("ok", mid, seq, tag, encode_state(mid, seq, r, list(r.collide_objects), tag)))
        except ProtocolError as e:
            outcomes.append(("error", e.kind, e.path))
    assert outcomes[0] == outcomes[1]
    assert (outcomes[0][0] == "ok") == accepted
    if not accepted:
        assert _plain_state(wire) is None


# -- whole messages from packed states ------------------------------------------------------------------
def test_messages_from_packed_states_are_the_plain_encoding() -> None:
    st_map = encode_state(11, 4, RESULTS[0], [9], None)
    packed = msgpack.packb(st_map, use_bin_type=True)
    assert state_message(packed) == msgpack.packb({"v": 1, "state": st_map}, use_bin_type=True)
    for n in (0, 1, 15, 16, 100, (1 << 16) - 1, 1 << 16):
        entries = [packed] * min(n, 3) + [msgpack.packb(k) for k in range(n - min(n, 3))]
        expected = msgpack.packb({"v": 1, "results": [msgpack.unpackb(e) for e in entries]}, use_bin_type=True)
        assert results_message(entries) == expected, n
    assert array_header(15) == b"\x9f" and array_header(16) == b"\xdc\x00\x10"


# -- the State packed without its map ----------------------------------------------------------------------
uint64s = st.sampled_from([0, 1, 127, 128, 255, 256, 65535, 65536, (1 << 32) - 1, 1 << 32, (1 << 64) - 1])
finite = st.floats(allow_nan=False, allow_infinity=False)
vec3s = st.builds(Vec3, finite, finite, finite)


@settings(max_examples=300, deadline=None)
@given(
    mover_id=uint64s, seq=uint64s, cell=st.integers(0, (1 << 32) - 1), origin=vec3s,
    quat=st.tuples(finite, finite, finite, finite), ok=st.booleans(), contact=st.booleans(), walk=st.booleans(),
    water=st.booleans(), ts=st.sampled_from(["OK", "Collided", "Adjusted", "Slid", "Invalid", "NoTransition", "é" * 40]),
    plane=st.none() | st.builds(Plane, vec3s, finite), plane_cell=st.none() | st.integers(0, (1 << 32) - 1),
    cn=st.none() | vec3s, sn=st.none() | vec3s, fsf=st.none() | st.integers(0, 3) | st.integers(-5, 1 << 40),
    transient=st.lists(st.sampled_from(["Contact", "OnWalkable", "Sliding", "WaterContact", "StationaryFall"]),
                       max_size=5),
    ids=st.lists(uint64s, max_size=20),
    tag=st.none() | st.integers(-(1 << 63), (1 << 64) - 1) | st.text(max_size=256),
)
def test_packed_states_decode_to_the_state_map(mover_id: int, seq: int, cell: int, origin: Vec3, quat: Any,
                                               ok: bool, contact: bool, walk: bool, water: bool, ts: str,
                                               plane: Plane | None, plane_cell: int | None, cn: Vec3 | None,
                                               sn: Vec3 | None, fsf: int | None, transient: list[str],
                                               ids: list[int], tag: Any) -> None:
    r = MoveResult(ok, Position.at(cell, origin, Quat(*quat)), ts, contact, walk, plane, plane_cell, cn, sn, water,
                   fsf, transient, [])
    expected = encode_state(mover_id, seq, r, ids, tag)
    got = msgpack.unpackb(pack_state(mover_id, seq, r, ids, tag), raw=False)
    assert got == expected
    assert list(got) == list(expected)  # the same keys in the same order
    # every real is sent as float64, whatever its value
    assert all(type(v) is float for v in got["position"]["origin"] + got["position"]["orientation"])


def test_packed_state_bytes_for_a_known_state() -> None:
    """Byte by byte for one State: fixed-width ints (cf/ce/cd) are valid msgpack for the same values."""
    r = _result(contact_plane=None, contact_plane_cell=None, collision_normal=None, sliding_normal=None,
                frames_stationary_fall=None, transient_state=[], collide_objects=[], water_contact=False)
    b = pack_state(11, 4, r, [])
    assert b[:3] == b"\xde\x00\x10"  # a map of 16 entries
    assert b[3:6] == b"\xa2id" and b[6:15] == b"\xcf" + (11).to_bytes(8, "big")
    assert msgpack.unpackb(b)["position"]["cell"] == CELL
    assert pack_state(11, 4, r, [], "t")[:3] == b"\xde\x00\x11"  # 17 with the tag


# -- the queue's idle flag (a request runs in a callback only when the queue is idle) ------------------------
def test_queue_is_idle_only_when_every_queued_job_has_finished() -> None:
    q = JobQueue(4)
    assert q.idle
    assert q.offer(lambda: None)
    q.put_priority(lambda: None)
    for _ in range(2):
        job = q.get(timeout=0.1)
        assert job is not None and not q.idle  # handed out but not finished: still not idle
        job()
        q.task_done()
    assert q.idle
