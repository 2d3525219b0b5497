"""The msgspec Structs generated from the map declarations (service/protocol/structs.py): their fields are
the declaration's, in its order (read from the Map, and for the written order from the bytes the service
packs), a field added to a map is a field of its Struct, and the bounds its kinds state refuse what they
should. Values at and beyond the bounds are chosen by hand."""

from __future__ import annotations

import math
from typing import Any, get_args

import msgpack
import msgspec
import pytest

from engine import MoveResult
from engine.geometry import Plane, Position, Vec3
from service.protocol import messages
from service.protocol.codec import pack_state
from service.protocol.messages import MOVE, STATE, TARGET
from service.protocol.move_structs import MoveS, TargetS
from service.protocol.schema import Field, Map
from service.protocol.schema_kinds import Enum, Int, Kind, ListOf, Number, Quaternion, Range, Str, Tag, UInt, Vector
from service.protocol.structs import field_names, struct_of

F32_MAX = 3.4028234663852886e38  # the largest float32, written out
CELL = 0xA9B40001


def _maps() -> list[Map]:
    return [m for m in vars(messages).values() if isinstance(m, Map)]


def _decode(struct: Any, value: Any) -> Any:
    return msgspec.msgpack.decode(msgpack.packb(value, use_bin_type=True), type=struct)


def test_every_maps_struct_has_its_fields_in_its_order() -> None:
    maps = _maps()
    assert len(maps) >= 15  # every map-form message, and the maps inside them
    for m in maps:
        struct = struct_of(m)
        assert field_names(struct) == tuple(f.name for f in m.fields), m.name
        info = msgspec.inspect.type_info(struct)
        assert isinstance(info, msgspec.inspect.StructType)
        required = {f.name for f in info.fields if f.required}
        assert required == {f.name for f in m.fields if f.required and f.with_field is None and f.read}, m.name


def test_the_services_move_structs_are_moves_and_targets() -> None:
    assert field_names(MoveS) == ("id", "tag", "to", "offset", "motion", "dt", "velocity")
    assert field_names(TargetS) == ("cell", "origin", "orientation")
    to_type = next(f.type for f in msgspec.structs.fields(MoveS) if f.name == "to")
    assert get_args(to_type)[0] is TargetS  # one Struct per map and options


def test_the_written_order_is_the_order_of_the_packed_bytes() -> None:
    result = MoveResult(True, Position.at(CELL, Vec3(1.0, 2.0, 3.0)), "OK", True, True, Plane(Vec3(0.0, 0.0, 1.0), 0.5),
                        CELL, Vec3(1.0, 0.0, 0.0), Vec3(0.0, 1.0, 0.0), True, 2, ["Contact"], [])
    packed = msgpack.unpackb(pack_state(7, 1, result, [3], "tag"))
    struct = struct_of(STATE, written_order=True)
    assert field_names(struct) == tuple(packed)
    assert field_names(struct)[-1] == "tag" and field_names(struct_of(STATE))[2] == "tag"


def test_a_field_added_to_a_map_is_in_its_struct() -> None:
    small = Map("Small", (Field("a", UInt(32), required=True), Field("b", Str())))
    grown = Map("Small", (*small.fields, Field("c", Number(), required=True)))
    assert field_names(struct_of(small)) == ("a", "b")
    assert field_names(struct_of(grown)) == ("a", "b", "c")
    got = _decode(struct_of(grown), {"a": 4, "c": 2.5})
    assert (got.a, got.b, got.c) == (4, None, 2.5)
    with pytest.raises(msgspec.ValidationError, match="missing required field `c`"):
        _decode(struct_of(grown), {"a": 4})


REFUSED = [
    ("a cell of 2**32", {"cell": 1 << 32, "origin": [0.0, 0.0, 0.0]}),
    ("a negative cell", {"cell": -1, "origin": [0.0, 0.0, 0.0]}),
    ("a real beyond float32", {"origin": [3.5e38, 0.0, 0.0]}),
    ("a real below float32", {"origin": [0.0, -3.5e38, 0.0]}),
    ("NaN", {"origin": [0.0, 0.0, math.nan]}),
    ("infinity", {"origin": [math.inf, 0.0, 0.0]}),
    ("a vector of 2", {"origin": [0.0, 0.0]}),
    ("a quaternion of 3", {"origin": [0.0, 0.0, 0.0], "orientation": [1.0, 0.0, 0.0]}),
    ("a string for a number", {"origin": ["1", 0.0, 0.0]}),
    ("a boolean for a cell", {"cell": True, "origin": [0.0, 0.0, 0.0]}),
]


@pytest.mark.parametrize("what, value", REFUSED, ids=[r[0] for r in REFUSED])
def test_a_targets_bounds_refuse(what: str, value: Any) -> None:
    with pytest.raises(msgspec.ValidationError):
        _decode(TargetS, value)
    with pytest.raises(msgspec.ValidationError):
        msgspec.convert(value, TargetS)


def test_values_at_the_bounds_are_taken() -> None:
    got = _decode(TargetS, {"cell": (1 << 32) - 1, "origin": [F32_MAX, -F32_MAX, 0.0]})
    assert got.cell == (1 << 32) - 1 and got.origin == (F32_MAX, -F32_MAX, 0.0) and got.orientation is None


@pytest.mark.parametrize("value", [{"id": -1}, {"id": 0, "tag": "x" * 257}, {"id": 0, "tag": 1.5},
                                   {"id": 0, "offset": [0.0, 0.0, math.nan]}])
def test_a_moves_bounds_refuse(value: Any) -> None:
    with pytest.raises(msgspec.ValidationError):
        _decode(MoveS, value)


def test_a_moves_id_and_tag_take_their_extremes() -> None:
    got = _decode(MoveS, {"id": (1 << 64) - 1, "tag": "x" * 256, "dt": "not read"})
    assert (got.id, got.tag, got.dt) == ((1 << 64) - 1, "x" * 256, "not read")  # dt: given to the post-pass as is
    assert _decode(MoveS, {"id": 0, "tag": -(1 << 63)}).tag == -(1 << 63)


def test_each_kind_bounds_what_it_states() -> None:
    m = Map("Kinds", (
        Field("dt", Number(Range(0.0, True, 2.0, "in (0, 2]")), required=True),
        Field("radius", Number(Range(0.0, False, None, "not negative"))),
        Field("lb", UInt(16)),
        Field("mode", Enum(("each", "batch"))),
        Field("names", ListOf(Str(), 2, 1, "at least one")),
        Field("count", Int()),
        Field("tag", Tag()),
        Field("q", Quaternion(tuple)),
        Field("v", Vector()),
    ))
    struct = struct_of(m)
    assert _decode(struct, {"dt": 2.0, "radius": 0.0, "lb": 0xFFFF, "mode": "batch", "names": ["a", "b"], "count": -3,
                            "q": [1.0, 0.0, 0.0, 0.0]}).names == ["a", "b"]
    for bad in ({"dt": 0.0}, {"dt": 2.5}, {"dt": 1.0, "radius": -0.1}, {"dt": 1.0, "lb": 0x10000},
                {"dt": 1.0, "mode": "all"}, {"dt": 1.0, "names": []}, {"dt": 1.0, "names": ["a", "b", "c"]},
                {"dt": 1.0, "names": [1]}, {"dt": 1.0, "count": 1.0}, {"dt": 1.0, "q": [1.0, 0.0, 0.0, math.nan]}):
        with pytest.raises(msgspec.ValidationError):
            _decode(struct, bad)


def test_nil_is_taken_where_the_default_is_nil() -> None:
    struct = struct_of(STATE)
    state = msgpack.unpackb(pack_state(7, 1, MoveResult(True, Position.at(CELL, Vec3(1.0, 2.0, 3.0)), "OK", False,
                                                        False, None, None, None, None, False, None, [], []), []))
    got = _decode(struct, state)
    assert got.contact_plane is None and got.frames_stationary_fall is None and got.water_contact is False
    assert got.tag is None and got.transient_state == [] and got.position.orientation is not None
    with pytest.raises(msgspec.ValidationError):  # a default that is not nil: nil is refused
        _decode(struct, {**state, "water_contact": None})
    # a field written but never read (the cell's landblock) takes any value, as STATE's readers ignore it
    assert _decode(struct, {**state, "landblock": "any"}).landblock == "any"


def test_the_options_say_what_a_map_cannot() -> None:
    exact = struct_of(STATE, required=("position.orientation",), leave_out=("collide_objects",),
                      types={"landblock": int | None}, forbid_unknown_fields=True, gc=False)
    state = msgpack.unpackb(pack_state(7, 1, MoveResult(True, Position.at(CELL, Vec3(1.0, 2.0, 3.0)), "OK", False,
                                                        False, None, None, None, None, False, None, [], []), []))
    del state["collide_objects"]
    assert _decode(exact, state).landblock == CELL >> 16
    assert "collide_objects" not in field_names(exact)
    for bad in ({**state, "position": {"cell": CELL, "origin": [1.0, 2.0, 3.0]}}, {**state, "collide_objects": []},
                {**state, "landblock": "any"}, {**state, "extra": 1}):
        with pytest.raises(msgspec.ValidationError):
            _decode(exact, bad)
    assert exact.__struct_config__.gc is False and exact.__struct_config__.forbid_unknown_fields is True
    envelope = struct_of(TARGET, first=(("v", int),))
    assert field_names(envelope) == ("v", "cell", "origin", "orientation")


def test_an_option_naming_no_field_is_an_error() -> None:
    with pytest.raises(ValueError, match="no field position.orient"):
        struct_of(STATE, required=("position.orient",))
    with pytest.raises(ValueError, match="no field velocty"):
        struct_of(MOVE, types={"velocty": Any})


def test_a_kind_without_a_struct_type_is_named() -> None:
    class Odd(Kind):
        pass

    with pytest.raises(TypeError, match="Odd"):
        struct_of(Map("WithOdd", (Field("x", Odd()),)))
    assert field_names(struct_of(Map("WithOdd", (Field("x", Odd()),)), types={"x": int})) == ("x",)


def test_a_state_replys_unread_landblock_reads_as_the_usual_reader_reads_it() -> None:
    """The client's State reply (clients/state_reply.py): a landblock STATE does not read is not checked
    there either, and the reply gives what the usual reader gives."""
    from clients.request_channel import unpack_message
    from clients.state_reply import decode_state_reply
    from clients.types import MoverState
    from service.protocol.frames import state_message

    reply = unpack_message(state_message(pack_state(7, 1, MoveResult(
        True, Position.at(CELL, Vec3(1.0, 2.0, 3.0)), "OK", True, True, None, None, None, None, False, None, [], []), [])))
    for landblock in ("any", 1 << 40, None):
        payload = msgpack.packb({**reply, "state": {**reply["state"], "landblock": landblock}}, use_bin_type=True)
        got = decode_state_reply(payload)
        assert got is not None and repr(got) == repr(MoverState.from_wire(unpack_message(payload)["state"]))
