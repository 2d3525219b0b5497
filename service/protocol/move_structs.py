"""The map-form move (docs/protocol.md, "Move request") read with msgspec: typed Structs, a post-pass for
what they cannot say, and msgspec's errors as the protocol's kinds and paths.

Why msgspec: docs/performance.md ("Wire decoding") measured these Structs, with this post-pass and
this error mapping, faster than the readers service/protocol/schema.py generated for MOVE, with every
error kind and path docs/protocol.md promises kept. A one-move request as clients send it is decoded
straight from its bytes (`plain_single_move`, for service/bus/node.py); every other request, and any
fault, is read from the request map msgpack gave, the Structs filled by `msgspec.convert` from its values.

The Structs are generated from MOVE's and TARGET's declarations (service/protocol/structs.py), and say
what their kinds bound (`msgspec.Meta`): a real within float32's range (NaN and ±infinity fail that bound
too), a cell's 32 bits, an id that is not negative, a tag's 256 characters, vectors of 3 and quaternions
of 4 numbers (fixed tuples). What they cannot say is `move_item`'s post-pass: exactly one of
to/offset/motion, `dt` with `motion` only (it is not read otherwise, as MOVE declares it) and no
`velocity` then, the unit quaternion, the engine's motion limit, the 64-bit upper bounds of an id and an
integer tag (Meta takes int64 bounds only), and arrays that are msgpack's (lists: `convert` takes a
Python tuple as well). It builds the MoveItem the core runs, with the engine's Vec3 and Quat.

msgspec's errors carry no kind: `protocol_error` reads it from msgspec's English message, which is not a
documented interface, so the dependency's version is bounded in pyproject.toml, and
tests/service/protocol/test_move_structs.py holds each message this mapping reads.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, TypeAlias

import msgspec

from engine import limits
from engine.geometry import Quat, Vec3
from engine.constants import HUGE_QUANTUM
from engine.limits import MAX_MOTION

from service.protocol.errors import ProtocolError
from service.protocol.messages import MOVE, MOVE_REQUEST, TARGET, MoveItem, Target, engine_check
from service.protocol.schema_kinds import Tag
from service.protocol.structs import struct_of
from service.protocol.validate import as_float, as_uint
from service.protocol.wire import PROTOCOL_VERSION, ErrorKind

__all__ = ["MoveS", "TargetS", "read_move", "read_moves", "move_item", "protocol_error",
           "plain_single_move"]

# -- the Structs, generated from MOVE's declaration ------------------------------------------------------
if TYPE_CHECKING:  # a Struct made at run time has no fields mypy could see: to it, any value
    MoveS: TypeAlias = Any
    TargetS: TypeAlias = Any
else:
    #: a move's `to` (messages.TARGET): cell and orientation default to the mover's own
    TargetS = struct_of(TARGET, gc=False)
    #: one move as messages.MOVE declares it (its `to`: TargetS). `dt` stays untyped: it belongs to `motion`
    #: and is read (by MOVE's own kind, its range there) only with it; sent with an offset it is ignored
    MoveS = struct_of(MOVE, gc=False, types={"dt": Any})

#: an id's and an integer tag's upper bound, and a tag's lower one: the post-pass's (Meta takes int64 bounds only)
_U64_END = 1 << 64
_TAG_MIN = -(1 << 63)

_ONE_OF = MOVE.one_of
#: `dt`'s kind (its range), read in full only when the usual float in (0, HUGE_QUANTUM] is not given
_DT = MOVE.by_name["dt"]
_excluded = MOVE.by_name["velocity"].excludes
assert _excluded is not None
#: why `velocity` may not come with `motion`, in the declaration's words
_VELOCITY_WHY: str = _excluded[1]
_check_motion = engine_check(limits.check_motion)
_TAG = Tag()
_MOVES = list[MoveS]


# -- the post-pass: what Meta cannot say, and the service's values --------------------------------------
def _tuple(path: str) -> ProtocolError:
    """An array given as a Python tuple: never msgpack's, but `convert` takes one where the bytes decoder
    would not, so a Python caller's values are refused as a sender's would be."""
    return ProtocolError(ErrorKind.WRONG_TYPE, f"{path}: expected array, got tuple", path)


def _unit(q: tuple[float, float, float, float], path: str) -> Quat:
    """A given orientation of unit length (validate.as_quat's rule and words), as the engine's Quat."""
    w, x, y, z = q
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if abs(n - 1.0) > 1e-3:
        raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: quaternion length {n:.6g} is not 1", path)
    return Quat(w, x, y, z)


def _not_one(m: MoveS, path: str) -> ProtocolError:
    given = [k for k in _ONE_OF if getattr(m, k) is not None]
    return ProtocolError(ErrorKind.MISSING_FIELD if not given else ErrorKind.BAD_VALUE,
                         f"{path}: give exactly one of to, offset, motion (got {' and '.join(given) or 'none'})", path)


def move_item(m: MoveS, path: str, raw: dict[str, Any] | None = None) -> MoveItem:
    """A typed move to the MoveItem the core runs; ProtocolError naming the field for what the Structs
    cannot check. `raw`: the map it was converted from (None: decoded from bytes, no tuples there).
    Straight-line per form (offset, to, motion): it runs for every move, and is most of a move's decoding."""
    mid, tag, velocity = m.id, m.tag, m.velocity
    if mid >= _U64_END:
        raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}.id: {mid} is not a 64-bit unsigned integer", f"{path}.id")
    if type(tag) is int and not _TAG_MIN <= tag < _U64_END:
        _TAG.read(tag, f"{path}.tag")  # raises: out of 64-bit range
    if raw is not None and velocity is not None and type(raw["velocity"]) is not list:
        raise _tuple(f"{path}.velocity")
    to, offset, motion = m.to, m.offset, m.motion
    if offset is not None:
        if to is not None or motion is not None:
            raise _not_one(m, path)
        if raw is not None and type(raw["offset"]) is not list:
            raise _tuple(f"{path}.offset")
        return MoveItem(path, mid, tag, None, Vec3(*offset), None, None, None if velocity is None else Vec3(*velocity))
    if to is not None:
        if motion is not None:
            raise _not_one(m, path)
        q = to.orientation
        if raw is not None:
            rt = raw["to"]
            if type(rt["origin"]) is not list:
                raise _tuple(f"{path}.to.origin")
            if q is not None and type(rt["orientation"]) is not list:
                raise _tuple(f"{path}.to.orientation")
        if q is None:
            return MoveItem(path, mid, tag, Target(to.cell, Vec3(*to.origin), None), None, None, None,
                            None if velocity is None else Vec3(*velocity))
        w, x, y, z = q
        if not abs(math.sqrt(w * w + x * x + y * y + z * z) - 1.0) <= 1e-3:  # as validate.as_quat
            _unit(q, f"{path}.to.orientation")  # raises, in as_quat's words
        target = Target(to.cell, Vec3(*to.origin), Quat(w, x, y, z))
        return MoveItem(path, mid, tag, target, None, None, None, None if velocity is None else Vec3(*velocity))
    if motion is None:
        raise _not_one(m, path)
    if raw is not None and type(raw["motion"]) is not list:
        raise _tuple(f"{path}.motion")
    dt = m.dt
    if dt is None:
        raise ProtocolError(ErrorKind.MISSING_FIELD, f"{path}.dt: required field is missing", f"{path}.dt")
    if type(dt) is not float or not 0.0 < dt <= HUGE_QUANTUM:  # NaN fails too: MOVE's kind reads and names it
        dt = _DT.kind.read(dt, f"{path}.dt")
    if velocity is not None:
        raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}.velocity: {_VELOCITY_WHY}", f"{path}.velocity")
    x, y, z = motion
    if not (-MAX_MOTION <= x <= MAX_MOTION and -MAX_MOTION <= y <= MAX_MOTION and -MAX_MOTION <= z <= MAX_MOTION):
        _check_motion(Vec3(x, y, z), f"{path}.motion")  # the engine's limit, in its words
    return MoveItem(path, mid, tag, None, None, Vec3(x, y, z), dt, None)


def read_move(value: Any, path: str) -> MoveItem:
    """One move of a request map (`move`, or an item of `moves`) to its MoveItem, or the ProtocolError
    naming the field (`moves[3].to.origin[2]`)."""
    try:
        m = msgspec.convert(value, MoveS)
    except msgspec.ValidationError as e:
        raise _rules_first(value, path, protocol_error(e, value, path)) from None
    return move_item(m, path, value)


# -- a plain single move straight from the payload's bytes ------------------------------------------------
#: `{"v", "move", "publish"?}` and nothing else, nor in the move (MOVE_REQUEST without its batch's `moves`):
#: the one-move request as clients send it
_SingleMoveRequest = struct_of(
    MOVE_REQUEST, name="SingleMoveRequest",
    first=(("v", int),),  # the envelope's version, which no map declares
    leave_out=("moves",),  # a batch is left to the request map's path
    required=("move",),  # MOVE_REQUEST's one_of, with `moves` left out
    types={"move.dt": Any},  # as MoveS's
    forbid_unknown_fields=True, gc=False)
_decode_single: Callable[[bytes], Any] = msgspec.msgpack.Decoder(_SingleMoveRequest).decode


def plain_single_move(payload: bytes) -> tuple[MoveItem, bool] | None:
    """A one-move request's MoveItem and whether its State goes to P/states (`"publish": "batch"`), read
    straight from the payload's bytes; None for anything else: another message, a field no Struct names
    (a batch's `moves`, a column request's `columns`, an unknown one), or a fault of any kind. The caller
    then takes the request map's path (requests.decode_envelope, parse_single_move), which says what is
    wrong in the protocol's words: only a request that path accepts as it is gets here an answer of its
    own, and the same MoveItem (its move's Structs are MoveS's with no unknown field, and the post-pass is
    the same)."""
    try:
        req = _decode_single(payload)
    except msgspec.DecodeError:  # ValidationError is one too
        return None
    if req.v != PROTOCOL_VERSION:
        return None
    publish = req.publish  # one of MOVE_REQUEST's modes, or nil for its default ("each")
    try:
        return move_item(req.move, "move"), publish is not None and publish == "batch"
    except ProtocolError:
        return None


_FIELD = re.compile(r"\.(\w+)")
#: the index of the list item msgspec's error is in (its path after `$`)
_FIRST = re.compile(r"^\[(\d+)\]")


def _rules_first(value: Any, path: str, err: ProtocolError) -> ProtocolError:
    """On the error path only: MOVE's rules before the values they concern, as its declaration orders
    them. A move that gives both `to` and `offset` is refused for that even when one of them is also
    malformed, and `velocity` with `motion` for being there at all (msgspec checks each value first)."""
    field = _FIELD.match(err.path[len(path):]) if err.path and isinstance(value, dict) else None
    if field is None or field.group(1) not in (*_ONE_OF, "dt", "velocity"):
        return err
    given = [k for k in _ONE_OF if value.get(k) is not None]
    if len(given) != 1:
        return ProtocolError(ErrorKind.MISSING_FIELD if not given else ErrorKind.BAD_VALUE,
                             f"{path}: give exactly one of to, offset, motion (got {' and '.join(given) or 'none'})", path)
    if field.group(1) == "velocity" and given == ["motion"]:
        return ProtocolError(ErrorKind.BAD_VALUE, f"{path}.velocity: {_VELOCITY_WHY}", f"{path}.velocity")
    return err


def read_moves(values: list[Any], path: str) -> list[MoveItem | ProtocolError]:
    """A batch's moves (`values` already a list within the batch limit), each its MoveItem or its own
    error, so that a bad move fails only itself (docs/protocol.md, "Batches"). The list is converted at
    once; msgspec stops at the first move that does not convert, so the moves before it are converted
    again as one list, that move's error is mapped from the failure, and the rest goes on as a list."""
    out: list[MoveItem | ProtocolError] = []
    start, n = 0, len(values)
    while start < n:
        rest = values[start:] if start else values
        failed: ProtocolError | None = None
        try:
            typed = msgspec.convert(rest, _MOVES)
        except msgspec.ValidationError as e:
            text, key, rel = _split(str(e))
            at = _FIRST.match(rel)
            bad = int(at.group(1)) if at is not None else 0
            typed = msgspec.convert(rest[:bad], _MOVES) if bad else []
            if at is not None:  # that move's error, from this one failure (its path within the move)
                p = f"{path}[{start + bad}]"
                failed = _rules_first(rest[bad], p, _mapped(text, key, rel[at.end():], rest[bad], p))
        else:
            bad = len(rest)
        for i, m in enumerate(typed, start):
            try:
                out.append(move_item(m, f"{path}[{i}]", values[i]))
            except ProtocolError as err:
                out.append(err)
        start += bad
        if start < n:  # the move that did not convert: its error
            if failed is None:
                try:
                    out.append(read_move(values[start], f"{path}[{start}]"))
                except ProtocolError as err:
                    out.append(err)
            else:
                out.append(failed)
            start += 1
    return out


# -- msgspec's errors as the protocol's --------------------------------------------------------------
_STEP = re.compile(r"\.([A-Za-z_]\w*)|\[(\d+)\]")
_MISSING = re.compile(r"^Object missing required field `(\w+)`")
_UNKNOWN = re.compile(r"^Object contains unknown field `(\w+)`")
_EXPECTED = re.compile(r"^Expected `([^`]*)`, got `(\w+)`")
_BOUND = re.compile(r"^Expected `(float|int)` ([<>]=?) ")
_LENGTH = re.compile(r"^Expected `(array|str)` of length (<=|>=)? ?(\d+)(?:, got (\d+))?")
#: msgspec's type names in validate.py's words: what was expected, and what came (a float is a number)
_WORDS = {"int": "integer", "float": "number", "str": "string", "object": "map", "array": "array", "bool": "boolean",
          "bytes": "binary", "ext": "extension", "null": "nil", "None": "nil"}
_GOT = {**_WORDS, "float": "float"}


def _split(message: str) -> tuple[str, bool, str]:
    """msgspec's message as its text, whether the fault is a map's key, and the path after its `$`
    (`Expected ... - at `$.to.origin[2]``, `... - at `key` in `$.to``; no path: the value itself)."""
    text, sep, where = message.rpartition(" - at `")
    if not sep:
        return message, False, ""
    key = where.startswith("key` in `")
    if key:
        where = where[len("key` in `"):]
    return text, key, where[1:-1]


def _join(prefix: str, rel: str) -> str:
    """`moves[3]` and `.to.origin[2]` (msgspec's path after its `$`) to `moves[3].to.origin[2]`."""
    rel = rel[1:] if rel.startswith(".") else rel
    if not prefix or not rel:
        return prefix or rel
    return prefix + rel if rel.startswith("[") else f"{prefix}.{rel}"


def _value_at(value: Any, rel: str) -> Any:
    """The value a msgspec path points at, within what was decoded or converted (error paths only)."""
    for key, index in _STEP.findall(rel):
        value = value[key] if key else value[int(index)]
    return value


def _words(types: str) -> str:
    return " or ".join(_WORDS.get(t, t) for t in types.split(" | ") if t != "null")


def protocol_error(e: msgspec.ValidationError | msgspec.DecodeError, value: Any, prefix: str = "") -> ProtocolError:
    """A msgspec error as docs/protocol.md's: its kind and path, and a message in validate.py's words.
    `value`: what msgspec read (the converted map, or the bytes' values decoded again); `prefix`: its
    path in the request (`moves[3]`)."""
    if not isinstance(e, msgspec.ValidationError):
        return ProtocolError(ErrorKind.MALFORMED, f"payload is not valid msgpack: {e}")
    return _mapped(*_split(str(e)), value, prefix)


def _mapped(text: str, key: bool, rel: str, value: Any, prefix: str) -> ProtocolError:
    """protocol_error's mapping of a message split by `_split`."""
    path = _join(prefix, rel)
    if key:  # a map key that is not a string
        return ProtocolError(ErrorKind.WRONG_TYPE, f"{path or 'message'}: map keys must be strings", path or None)
    if not path and text.startswith("Expected `object`"):
        return ProtocolError(ErrorKind.MALFORMED, f"payload is msgpack but not a map: {text}")
    if (missing := _MISSING.match(text)) is not None:
        path = _join(path, "." + missing.group(1))
        return ProtocolError(ErrorKind.MISSING_FIELD, f"{path}: required field is missing", path)
    if (unknown := _UNKNOWN.match(text)) is not None:
        path = _join(path, "." + unknown.group(1))
        return ProtocolError(ErrorKind.BAD_VALUE, f"{path}: not a known field", path)
    if (got := _EXPECTED.match(text)) is not None:
        if got.group(2) in ("null", "None") and not path.endswith("]"):  # a required field's nil: absent
            return ProtocolError(ErrorKind.MISSING_FIELD, f"{path}: required field is missing", path)
        return ProtocolError(ErrorKind.WRONG_TYPE,
                             f"{path}: expected {_words(got.group(1))}, got {_GOT.get(got.group(2), got.group(2))}",
                             path)
    if (bound := _BOUND.match(text)) is not None or text.startswith("Number out of range"):
        found = _value_at(value, rel)
        if bound is None or bound.group(1) == "float":
            try:  # non_finite for NaN and ±infinity, bad_value beyond float32, in validate.py's words
                as_float(found, path)
            except ProtocolError as err:
                return err
            return ProtocolError(ErrorKind.BAD_VALUE, f"{path}: {found!r} {text[len('Expected `float` '):]}", path)
        try:  # what no unsigned integer of those bits holds, in validate.py's words
            as_uint(found, path, 32 if "4294967295" in text else 64)
        except ProtocolError as err:
            return err
        return ProtocolError(ErrorKind.BAD_VALUE, f"{path}: {found} is out of range ({text[len('Expected `int` '):]})",
                             path)
    if (length := _LENGTH.match(text)) is not None:
        if length.group(1) == "str":
            return ProtocolError(ErrorKind.TOO_LARGE, f"{path}: longer than {length.group(3)} characters", path)
        if length.group(2) == "<=":
            return ProtocolError(ErrorKind.TOO_LARGE, f"{path}: at most {length.group(3)} items allowed", path)
        return ProtocolError(ErrorKind.BAD_VALUE, f"{path}: expected {length.group(3)} numbers, got {length.group(4)}",
                             path)
    if text.startswith("Invalid enum value"):
        return ProtocolError(ErrorKind.BAD_VALUE, f"{path}: {text}", path)
    return ProtocolError(ErrorKind.BAD_VALUE, f"{path or 'message'}: {text}", path or None)

