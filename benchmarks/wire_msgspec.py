"""The move request and the column request declared as msgspec Structs: the candidate the wire-decoding
benchmark (benchmarks/bench_wire_decoding.py) weighs against the service's own schema (service/protocol/schema.py).

Not used by the service: msgspec is not a dependency of the project, and this module is imported only
when it is installed. What the Structs cannot say (`Meta` gives bounds and lengths, not "finite", "unit
length" or "exactly one of") is a post-pass in Python, which also builds the values the service runs
(`MoveItem` with the engine's Vec3 and Quat, `ColumnRequest` with numpy arrays), so that both sides are
timed from the same bytes to the same result. `protocol_error` maps a msgspec error to docs/protocol.md's
kind and path, reading msgspec's message text: the mapping depends on msgspec's wording, which is not a
documented interface.
"""

from __future__ import annotations

import math
import re
from typing import Annotated, Any, Literal

import msgpack
import msgspec
import numpy as np

from engine import limits
from engine.constants import HUGE_QUANTUM
from engine.geometry import Quat, Vec3
from service.protocol.column_request import ColumnRequest, _bad_reals
from service.protocol.columns import FLOAT32_MAX, REQUEST_COLUMNS
from service.protocol.errors import ProtocolError
from service.protocol.messages import MoveItem, Target, engine_check
from service.protocol.requests import MoveBatch
from service.protocol.schema_kinds import MAX_TAG_LEN
from service.protocol.wire import MAX_BATCH, MAX_PAYLOAD, PROTOCOL_VERSION, ErrorKind

__all__ = ["decode_structs", "decode_single", "decode_batch", "decode_batch_typed", "decode_columns", "decode_register_id",
           "protocol_error"]

# -- the declarations ---------------------------------------------------------------------------------
#: a real: NaN fails both bounds, so finiteness is expressed too (but refused as a bound, see protocol_error)
Real = Annotated[float, msgspec.Meta(ge=-FLOAT32_MAX, le=FLOAT32_MAX)]
Vector = tuple[Real, Real, Real]
QuatValue = tuple[Real, Real, Real, Real]
U32 = Annotated[int, msgspec.Meta(ge=0, le=0xFFFFFFFF)]
#: msgspec's Meta takes int64 bounds only, so "< 2**64" cannot be written; msgpack holds no larger int
U64 = Annotated[int, msgspec.Meta(ge=0)]
Tag = int | Annotated[str, msgspec.Meta(max_length=MAX_TAG_LEN)]
Dt = Annotated[float, msgspec.Meta(gt=0.0, le=HUGE_QUANTUM)]


class TargetS(msgspec.Struct):
    origin: Vector
    cell: U32 | None = None
    orientation: QuatValue | None = None


class MoveS(msgspec.Struct):
    id: U64
    tag: Tag | None = None
    to: TargetS | None = None
    offset: Vector | None = None
    motion: Vector | None = None
    dt: Dt | None = None
    velocity: Vector | None = None


class MoveRequestS(msgspec.Struct):
    """The whole request typed: one bad move fails the decoding of all (the fast path)."""

    v: int
    move: MoveS | None = None
    moves: Annotated[list[MoveS], msgspec.Meta(max_length=MAX_BATCH)] | None = None
    publish: Literal["each", "batch"] | None = None


class MoveRequestRawS(msgspec.Struct):
    """The request with its moves left as msgpack bytes, each decoded on its own (a bad one fails itself)."""

    v: int
    move: msgspec.Raw | None = None
    moves: Annotated[list[msgspec.Raw], msgspec.Meta(max_length=MAX_BATCH)] | None = None
    publish: Literal["each", "batch"] | None = None


class ColumnsS(msgspec.Struct, forbid_unknown_fields=True):  # type: ignore[call-arg]  # msgspec untyped here
    """Each column a view of the payload's bytes (msgspec decodes `bin` into a memoryview without a copy).
    A column name the form does not know is refused, as parse_column_request refuses it."""

    id: memoryview | None = None
    offset: memoryview | None = None
    to_cell: memoryview | None = None
    to_origin: memoryview | None = None
    to_orientation: memoryview | None = None
    motion: memoryview | None = None
    dt: memoryview | None = None
    velocity: memoryview | None = None


class ColumnRequestS(msgspec.Struct):
    v: int
    kind: Literal["offset", "to", "motion"]
    columns: ColumnsS
    publish: Literal["each", "batch", "columns"] | None = None
    move: msgspec.Raw | None = None
    moves: msgspec.Raw | None = None


class RegisterIdS(msgspec.Struct):
    """A register's `id` alone (the other fields are ignored as unknown keys): 0 is reserved."""

    id: Annotated[int, msgspec.Meta(ge=1)] | None = None


_REQUEST = msgspec.msgpack.Decoder(MoveRequestS)
_REQUEST_RAW = msgspec.msgpack.Decoder(MoveRequestRawS)
_MOVE = msgspec.msgpack.Decoder(MoveS)
_COLUMNS = msgspec.msgpack.Decoder(ColumnRequestS)
_REGISTER_ID = msgspec.msgpack.Decoder(RegisterIdS)
_check_motion = engine_check(limits.check_motion)


# -- the post-pass: what Meta cannot say, and the service's values --------------------------------------
def _unit(q: tuple[float, float, float, float], path: str) -> Quat:
    w, x, y, z = q
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if abs(n - 1.0) > 1e-3:
        raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: quaternion length {n:.6g} is not 1", path)
    return Quat(w, x, y, z)


def move_item(m: MoveS, path: str) -> MoveItem:
    """A decoded move to the service's MoveItem: exactly one of to/offset/motion, `dt` with `motion` and
    no `velocity` then, the unit quaternion and the engine's motion limit."""
    to, offset, motion = m.to, m.offset, m.motion
    given = (to is not None) + (offset is not None) + (motion is not None)
    if given != 1:
        what = "none" if not given else " and ".join(k for k, v in (("to", to), ("offset", offset), ("motion", motion))
                                                       if v is not None)
        raise ProtocolError(ErrorKind.MISSING_FIELD if not given else ErrorKind.BAD_VALUE,
                            f"{path}: give exactly one of to, offset, motion (got {what})", path)
    velocity = None if m.velocity is None else Vec3(*m.velocity)
    if offset is not None:
        return MoveItem(path, m.id, m.tag, None, Vec3(*offset), None, None, velocity)
    if to is not None:
        q = to.orientation
        target = Target(to.cell, Vec3(*to.origin), None if q is None else _unit(q, f"{path}.to.orientation"))
        return MoveItem(path, m.id, m.tag, target, None, None, None, velocity)
    assert motion is not None
    if m.dt is None:
        raise ProtocolError(ErrorKind.MISSING_FIELD, f"{path}.dt: required field is missing", f"{path}.dt")
    if velocity is not None:
        raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}.velocity: a physics step integrates its own velocity",
                            f"{path}.velocity")
    step = Vec3(*motion)
    _check_motion(step, f"{path}.motion")
    return MoveItem(path, m.id, m.tag, None, None, step, m.dt, None)


def _envelope(payload: bytes) -> None:
    if not payload:
        raise ProtocolError(ErrorKind.MALFORMED, "empty payload: expected a msgpack map")
    if len(payload) > MAX_PAYLOAD:
        raise ProtocolError(ErrorKind.TOO_LARGE, f"payload of {len(payload)} bytes exceeds {MAX_PAYLOAD}")


def _version(v: int) -> None:
    if v != PROTOCOL_VERSION:
        raise ProtocolError(ErrorKind.UNSUPPORTED_VERSION,
                            f"protocol version {v} is not supported (this service speaks {PROTOCOL_VERSION})", "v")


def _one_of(move: Any, moves: Any) -> None:
    if (move is None) == (moves is None):
        raise ProtocolError(ErrorKind.MISSING_FIELD if move is None else ErrorKind.BAD_VALUE,
                            "give exactly one of move (one move) or moves (a batch)")


def decode_structs(payload: bytes) -> MoveRequestS:
    """The typed decoding alone (no post-pass, no engine values): what msgspec itself costs."""
    return _REQUEST.decode(payload)


def decode_single(payload: bytes) -> MoveItem:
    """`{"v": 1, "move": Move}`: the one typed decoding, then the post-pass."""
    _envelope(payload)
    try:
        req = _REQUEST.decode(payload)
    except (msgspec.ValidationError, msgspec.DecodeError) as e:
        raise protocol_error(e, payload) from None
    _version(req.v)
    _one_of(req.move, req.moves)
    if req.move is None:
        raise ProtocolError(ErrorKind.BAD_VALUE, "expected one move")
    return move_item(req.move, "move")


def _item(raw: msgspec.Raw, path: str) -> MoveItem | ProtocolError:
    try:
        return move_item(_MOVE.decode(raw), path)
    except (msgspec.ValidationError, msgspec.DecodeError) as e:
        return protocol_error(e, bytes(raw), path)
    except ProtocolError as e:
        return e


def decode_batch(payload: bytes) -> list[MoveItem | ProtocolError]:
    """`{"v": 1, "moves": [...]}` with each move decoded on its own, as the protocol asks (a bad move
    fails only itself): the envelope with the moves as Raw bytes, then one typed decoding per move."""
    _envelope(payload)
    try:
        req = _REQUEST_RAW.decode(payload)
    except (msgspec.ValidationError, msgspec.DecodeError) as e:
        raise protocol_error(e, payload) from None
    _version(req.v)
    _one_of(req.move, req.moves)
    assert req.moves is not None
    return [_item(raw, f"moves[{i}]") for i, raw in enumerate(req.moves)]


def decode_batch_typed(payload: bytes) -> list[MoveItem | ProtocolError]:
    """The whole batch in one typed decoding; when a move is refused, again move by move
    (`decode_batch`), so that the others still run."""
    _envelope(payload)
    try:
        req = _REQUEST.decode(payload)
    except msgspec.ValidationError as e:
        if str(e).endswith("`") and "- at `$.moves[" in str(e):
            return decode_batch(payload)
        raise protocol_error(e, payload) from None
    except msgspec.DecodeError as e:
        raise protocol_error(e, payload) from None
    _version(req.v)
    _one_of(req.move, req.moves)
    assert req.moves is not None
    out: list[MoveItem | ProtocolError] = []
    for i, m in enumerate(req.moves):
        try:
            out.append(move_item(m, f"moves[{i}]"))
        except ProtocolError as e:
            out.append(e)
    return out


def as_batch(items: list[MoveItem | ProtocolError]) -> MoveBatch:
    """The service's MoveBatch of a decoded batch (its ItemErrors without the id and tag echo)."""
    from service.protocol.requests import ItemError

    return MoveBatch(False, [ItemError(i) if isinstance(i, ProtocolError) else i for i in items])


def decode_columns(payload: bytes) -> ColumnRequest:
    """A column request: the typed envelope (each column a memoryview), then parse_column_request's own
    checks of kinds and lengths, and its per-item checks of the values (the same numpy code)."""
    _envelope(payload)
    try:
        req = _COLUMNS.decode(payload)
    except (msgspec.ValidationError, msgspec.DecodeError) as e:
        raise protocol_error(e, payload) from None
    _version(req.v)
    if req.move is not None or req.moves is not None:
        raise ProtocolError(ErrorKind.BAD_VALUE, "give exactly one of move, moves or columns")
    kind, cols = req.kind, req.columns
    given: dict[str, memoryview] = {}
    for col in REQUEST_COLUMNS:
        raw = getattr(cols, col.name)
        path = f"columns.{col.name}"
        if raw is None:
            if kind in col.required:
                raise ProtocolError(ErrorKind.MISSING_FIELD, f"{path}: required for kind {kind}", path)
            continue
        if not col.allowed(kind):
            raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: not a column of kind {kind}", path)
        if len(raw) % col.item_bytes:
            raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: {len(raw)} bytes is not a whole number of items", path)
        given[col.name] = raw
    n = len(given["id"]) // 8
    if n > MAX_BATCH:
        raise ProtocolError(ErrorKind.TOO_LARGE, f"columns.id: {n} items, at most {MAX_BATCH} allowed", "columns.id")
    arrays: dict[str, np.ndarray[Any, Any]] = {}
    for col in REQUEST_COLUMNS:
        raw = given.get(col.name)
        if raw is None:
            continue
        if len(raw) // col.item_bytes != n:
            path = f"columns.{col.name}"
            raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: {len(raw) // col.item_bytes} items, but columns.id has {n}",
                                path)
        arrays[col.name] = np.frombuffer(raw, dtype=col.np_dtype).reshape((n,) if col.width == 1 else (n, col.width))
    out = ColumnRequest(kind, n, arrays, req.publish or "each")
    _bad_reals(out)
    return out


def decode_register_id(payload: bytes) -> int | None:
    try:
        return _REGISTER_ID.decode(payload).id
    except (msgspec.ValidationError, msgspec.DecodeError) as e:
        raise protocol_error(e, payload) from None


# -- msgspec's errors as the protocol's --------------------------------------------------------------
_AT = re.compile(r"^(?P<text>.*?)(?: - at `\$(?P<path>[^`]*)`)?$", re.S)
_STEP = re.compile(r"\.([A-Za-z_]\w*)|\[(\d+)\]")
_MISSING = re.compile(r"^Object missing required field `(\w+)`")
_UNKNOWN = re.compile(r"^Object contains unknown field `(\w+)`")
_EXPECTED = re.compile(r"^Expected `[^`]*`, got `(\w+)`")
_BOUND = re.compile(r"^Expected `(float|int)` [<>]=? ")
_LENGTH = re.compile(r"^Expected `(array|str)` of length (<=|>=)? ?\d+")


def _join(prefix: str, rel: str) -> str:
    """`moves[3]` and `.to.origin[2]` (msgspec's path after its `$`) to `moves[3].to.origin[2]`."""
    rel = rel[1:] if rel.startswith(".") else rel
    if not prefix:
        return rel
    return prefix + rel if rel.startswith("[") or not rel else f"{prefix}.{rel}"


def _value_at(data: bytes, rel: str) -> Any:
    """The value a path points at, read again from the bytes (on the error path only)."""
    value: Any = msgpack.unpackb(data, raw=False, strict_map_key=False)
    for key, index in _STEP.findall(rel):
        value = value[key] if key else value[int(index)]
    return value


def protocol_error(e: Exception, data: bytes, prefix: str = "") -> ProtocolError:
    """A msgspec DecodeError or ValidationError as docs/protocol.md's error: its kind and its path."""
    if isinstance(e, msgspec.DecodeError) and not isinstance(e, msgspec.ValidationError):
        return ProtocolError(ErrorKind.MALFORMED, f"payload is not valid msgpack: {e}")
    m = _AT.match(str(e))
    assert m is not None  # the pattern matches any text
    text, rel = m.group("text"), m.group("path") or ""  # no path: the value decoded itself (`$`)
    if "`key` in" in text:  # a map key that is not a string
        return ProtocolError(ErrorKind.WRONG_TYPE, "message: map keys must be strings", prefix or None)
    if not prefix and not rel and text.startswith("Expected `object`"):
        return ProtocolError(ErrorKind.MALFORMED, f"payload is msgpack but not a map: {text}")
    path = _join(prefix, rel)
    if (missing := _MISSING.match(text)) is not None:
        path = _join(path, "." + missing.group(1))
        return ProtocolError(ErrorKind.MISSING_FIELD, f"{path}: required field is missing", path)
    if (unknown := _UNKNOWN.match(text)) is not None:
        path = _join(path, "." + unknown.group(1))
        return ProtocolError(ErrorKind.BAD_VALUE, f"{path}: not a known field", path)
    if (got := _EXPECTED.match(text)) is not None:  # nil means absent: a required field's nil is missing
        kind = ErrorKind.MISSING_FIELD if got.group(1) == "None" else ErrorKind.WRONG_TYPE
        return ProtocolError(kind, f"{path}: {text}", path)
    if _BOUND.match(text):  # a bound; NaN and infinities fail one too
        value = _value_at(data, rel)
        finite = not isinstance(value, float) or math.isfinite(value)
        return ProtocolError(ErrorKind.BAD_VALUE if finite else ErrorKind.NON_FINITE, f"{path}: {text}", path)
    if (length := _LENGTH.match(text)) is not None:
        kind = ErrorKind.TOO_LARGE if length.group(2) == "<=" else ErrorKind.BAD_VALUE
        return ProtocolError(kind, f"{path}: {text}", path)
    if text.startswith("Invalid enum value"):
        return ProtocolError(ErrorKind.BAD_VALUE, f"{path}: {text}", path)
    return ProtocolError(ErrorKind.BAD_VALUE, f"{path}: {text} (not mapped)", path)
