"""The move's msgspec Structs (service/protocol/move_structs.py): they follow MOVE's declaration, and each
path of the error mapping that reads msgspec's wording, or that the post-pass handles itself, gives the
kind and path docs/protocol.md names ("Errors", "Limits on values").

msgspec's messages are not a documented interface: a new msgspec that words them otherwise fails here
first. Expected kinds and paths are the protocol's, written out by hand.
"""

from __future__ import annotations

import math
import re
from typing import Any

import msgspec
import pytest

from engine.geometry import Quat, Vec3
from service.protocol.errors import ProtocolError
from service.protocol.messages import MOVE, TARGET
from service.protocol.move_structs import MoveS, TargetS, read_move, read_moves
from service.protocol.requests import ItemError, parse_moves

OK = {"id": 7, "offset": [0.5, 0.0, 0.0]}


def _error(value: Any, path: str = "moves[0]") -> tuple[str, str | None]:
    with pytest.raises(ProtocolError) as e:
        read_move(value, path)
    return e.value.kind, e.value.path


def test_the_structs_follow_the_declaration() -> None:
    """Every field MOVE and TARGET declare, and no other; required where the declaration requires it
    (MOVE's `dt` is required only with `motion`, which the post-pass checks)."""
    for struct, decl in ((MoveS, MOVE), (TargetS, TARGET)):
        info = msgspec.inspect.type_info(struct)
        assert isinstance(info, msgspec.inspect.StructType)
        assert {f.name for f in info.fields} == {f.name for f in decl.fields if f.read}
        assert {f.name for f in info.fields if f.required} == decl.required_names


def test_a_usual_move_reads_into_the_engines_values() -> None:
    item = read_move({"id": 9, "tag": "w", "to": {"cell": 5, "origin": [1, 2, 3], "orientation": [0.0, 0.0, 0.0, 1.0]},
                      "velocity": [0.0, 0.0, -9.8]}, "move")
    assert (item.path, item.id, item.tag) == ("move", 9, "w")
    assert item.to is not None and item.to.cell == 5 and item.to.origin == Vec3(1.0, 2.0, 3.0)
    assert item.to.orientation == Quat(0.0, 0.0, 0.0, 1.0) and item.velocity == Vec3(0.0, 0.0, -9.8)
    step = read_move({"id": 1, "motion": [0.0, 2.0, 0.0], "dt": 0.25}, "move")
    assert step.motion == Vec3(0.0, 2.0, 0.0) and step.dt == 0.25 and step.offset is None


# (what, move, kind, path): each a single fault
CASES: list[tuple[str, Any, str, str]] = [
    ("nil for a required field is a missing field", {"id": None, "offset": [0.0, 0.0, 0.0]}, "missing_field", "moves[0].id"),
    ("nil for a target's origin", {"id": 1, "to": {"origin": None}}, "missing_field", "moves[0].to.origin"),
    ("nil inside a vector is a wrong type", {"id": 1, "offset": [None, 0.0, 0.0]}, "wrong_type", "moves[0].offset[0]"),
    ("a key that is not a string names its map", {"id": 1, "to": {"origin": [0.0, 0.0, 0.0], 5: 1}}, "wrong_type",
     "moves[0].to"),
    ("a move's own key that is not a string", {**OK, 3: "x"}, "wrong_type", "moves[0]"),
    ("NaN fails the float32 bound: non_finite", {"id": 1, "offset": [0.0, math.nan, 0.0]}, "non_finite",
     "moves[0].offset[1]"),
    ("-infinity", {"id": 1, "velocity": [0.0, 0.0, -math.inf], "offset": [0.0, 0.0, 0.0]}, "non_finite",
     "moves[0].velocity[2]"),
    ("finite beyond float32: bad_value", {"id": 1, "to": {"origin": [3.5e38, 0.0, 0.0]}}, "bad_value",
     "moves[0].to.origin[0]"),
    ("an integer beyond any float (msgspec: number out of range)", {"id": 1, "offset": [1 << 1100, 0.0, 0.0]},
     "non_finite", "moves[0].offset[0]"),
    ("an id of 2**64 (Meta cannot bound it)", {"id": 1 << 64, "offset": [0.0, 0.0, 0.0]}, "bad_value", "moves[0].id"),
    ("a negative id", {"id": -1, "offset": [0.0, 0.0, 0.0]}, "bad_value", "moves[0].id"),
    ("a cell of 2**32", {"id": 1, "to": {"cell": 1 << 32, "origin": [0.0, 0.0, 0.0]}}, "bad_value", "moves[0].to.cell"),
    ("a tag of 2**64", {**OK, "tag": 1 << 64}, "bad_value", "moves[0].tag"),
    ("a tag below -2**63", {**OK, "tag": -(1 << 63) - 1}, "bad_value", "moves[0].tag"),
    ("a tag of 257 characters", {**OK, "tag": "x" * 257}, "too_large", "moves[0].tag"),
    ("a tag that is a float", {**OK, "tag": 1.5}, "wrong_type", "moves[0].tag"),
    ("a vector of 4", {"id": 1, "offset": [0.0, 0.0, 0.0, 0.0]}, "bad_value", "moves[0].offset"),
    ("a Python tuple for an array", {"id": 1, "offset": (0.0, 0.0, 0.0)}, "wrong_type", "moves[0].offset"),
    ("a tuple inside the target", {"id": 1, "to": {"origin": (0.0, 0.0, 0.0)}}, "wrong_type", "moves[0].to.origin"),
    ("dt with motion: not a number", {"id": 1, "motion": [0.0, 0.0, 0.0], "dt": "x"}, "wrong_type", "moves[0].dt"),
    ("dt with motion: beyond 2 s", {"id": 1, "motion": [0.0, 0.0, 0.0], "dt": 2.5}, "bad_value", "moves[0].dt"),
    ("dt with motion: NaN", {"id": 1, "motion": [0.0, 0.0, 0.0], "dt": math.nan}, "non_finite", "moves[0].dt"),
    ("both to and offset, the offset malformed too: the rule first", {**OK, "offset": [0.0], "to": {"origin": 5}},
     "bad_value", "moves[0]"),
    ("none of to, offset, motion, a velocity malformed: the rule first", {"id": 1, "velocity": "x"}, "missing_field",
     "moves[0]"),
    ("velocity with motion, the velocity malformed: the rule first",
     {"id": 1, "motion": [0.0, 0.0, 0.0], "dt": 0.1, "velocity": "x"}, "bad_value", "moves[0].velocity"),
    ("not a map", [1, 2], "wrong_type", "moves[0]"),
]


@pytest.mark.parametrize("what,move,kind,path", CASES, ids=[c[0] for c in CASES])
def test_each_mapped_error_names_its_kind_and_path(what: str, move: Any, kind: str, path: str) -> None:
    assert _error(move) == (kind, path)
    with pytest.raises(ProtocolError) as e:
        read_move(move, "moves[0]")
    # the message starts with the path and names no Python or msgspec class (ValidationError, ...)
    assert e.value.message.startswith(path + ":")
    assert not re.search(r"\b[A-Z][A-Za-z]*(Error|Exception|Data)\b", e.value.message)
    assert "`" not in e.value.message and "$" not in e.value.message


def test_dt_without_motion_is_not_read() -> None:
    """MOVE declares `dt` with `motion`: sent with an offset it is ignored, whatever it holds."""
    assert read_move({**OK, "dt": "x"}, "move").offset == Vec3(0.5, 0.0, 0.0)
    assert read_move({**OK, "dt": math.nan}, "move").dt is None


def test_a_batch_reads_each_move_alone_whether_typed_at_once_or_not() -> None:
    good = [{"id": i, "offset": [0.25 * i, 0.0, 0.0]} for i in range(5)]
    whole = read_moves(good, "moves")  # every move converts: one conversion of the list
    assert whole == [read_move(m, f"moves[{i}]") for i, m in enumerate(good)]
    bad = [*good[:2], {"id": 2, "offset": [0.0, "x", 0.0]}, *good[3:]]  # one does not: move by move
    items = read_moves(bad, "moves")
    assert [type(i).__name__ for i in items] == ["MoveItem", "MoveItem", "ProtocolError", "MoveItem", "MoveItem"]
    err = items[2]
    assert isinstance(err, ProtocolError) and (err.kind, err.path) == ("wrong_type", "moves[2].offset[1]")
    assert items[4] == whole[4]
    post = [*good[:3], {"id": 3, "to": {"origin": [0.0, 0.0, 0.0], "orientation": [2.0, 0.0, 0.0, 0.0]}}]
    items = read_moves(post, "moves")  # converts, and the post-pass refuses one
    assert isinstance(items[3], ProtocolError) and items[3].path == "moves[3].to.orientation"
    assert items[:3] == whole[:3]


def _alone(values: list[Any]) -> list[Any]:
    out: list[Any] = []
    for i, v in enumerate(values):
        try:
            out.append(read_move(v, f"moves[{i}]"))
        except ProtocolError as e:
            out.append((e.kind, e.path))
    return out


def test_a_batch_with_several_bad_moves_reads_as_its_moves_alone() -> None:
    """The batch is converted in runs between the moves that do not convert: whatever the runs, each
    move's outcome is the one it has read alone (bad first and last, two in a row, a non-string key)."""
    good = [{"id": i, "offset": [0.25 * i, 0.0, 0.0]} for i in range(8)]
    values: list[Any] = [*good]
    values[0] = {"id": "0", "offset": [0.0, 0.0, 0.0]}
    values[3] = {"id": 3, "offset": [0.0, 0.0, 0.0], 7: "key"}
    values[4] = {"id": 4, "to": {"origin": [math.nan, 0.0, 0.0]}}
    values[7] = 5
    got = [(x.kind, x.path) if isinstance(x, ProtocolError) else x for x in read_moves(values, "moves")]
    assert got == _alone(values)
    assert [g for g in got if isinstance(g, tuple)] == [
        ("wrong_type", "moves[0].id"), ("wrong_type", "moves[3]"), ("non_finite", "moves[4].to.origin[0]"),
        ("wrong_type", "moves[7]")]


def test_a_failed_batch_item_echoes_its_id_and_tag() -> None:
    batch = parse_moves({"v": 1, "moves": [OK, {"id": 4, "tag": "t", "offset": [math.inf, 0.0, 0.0]},
                                           {"id": -1, "tag": "x" * 300, "offset": [0.0, 0.0, 0.0]}]})
    one, two = batch.items[1], batch.items[2]
    assert isinstance(one, ItemError) and (one.id, one.tag, one.error.kind) == (4, "t", "non_finite")
    # an id or tag the protocol does not allow is not echoed
    assert isinstance(two, ItemError) and (two.id, two.tag, two.error.kind) == (None, None, "bad_value")
