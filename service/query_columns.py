"""The column form of the spatial queries: its wire schema, declared once per op.

A column query carries N queries of one op (sight, ray, ground, place) as
packed little-endian arrays (msgpack `bin`), as a column move batch does
(service/columns.py), and its reply carries the answers the same way
(docs/protocol.md, "Query columns"). `QUERY_COLUMNS` below is the only place
the columns are listed: decoding and checking (`parse_query_columns`), the
service's encoding (`run_query_columns`), the client's packing and unpacking
(clients/spatial.py) and the test that reads docs/protocol.md's tables all
go through it.

Whole-request errors (a column of the wrong type, byte length or item
count, an unknown or missing column, too many items) refuse the request
before anything runs. Bad values fail only their item (NaN, ±infinity, a
magnitude beyond float32, a radius outside 0.001 .. 10 m, a start outside the key's
landblock, an unknown target): the others are answered as if sent alone,
each exactly as the map form answers the same query.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Final

import numpy as np

from engine.limits import MAX_RAY_RADIUS, MIN_SPHERE_RADIUS

from .column_request import _column_bytes, _type_name, refuse_bad_reals
from .columns import Column, pack_columns
from .errors import ProtocolError
from .wire import MAX_BATCH, PROTOCOL_VERSION, ErrorKind

__all__ = [
    "QueryColumns",
    "QUERY_COLUMNS",
    "BLOCKER_CODES",
    "PLACEMENT_CODES",
    "QUERY_FORMS",
    "QueryColumnRequest",
    "is_query_columns",
    "query_column_count",
    "parse_query_columns",
    "run_query_columns",
]

Array = np.ndarray[Any, Any]

#: Health's `query_forms`: the request forms every query op understands.
QUERY_FORMS: Final = ("single", "batch", "columns")
#: a reply's `blocker` code: the index in this tuple (engine.queries.results.BLOCKER_KINDS), 255 for none
BLOCKER_CODES: Final = ("terrain", "cell", "building", "object")
#: a place reply's `placement_result` code: the index in this tuple, 255 for a failed item
PLACEMENT_CODES: Final = ("OK", "NoValidPosition", "NoCell(lost)")
#: what a code column holds for "none" (and a failed item)
NO_CODE: Final = 255


@dataclass(frozen=True, slots=True)
class QueryColumns:
    """One op's column form: its request and reply columns and its reply `flags` bits (bit k is
    `flags[k]`; bit 0 is always `resolved`). A request column is `required` or `optional` for the op
    (Column.required / optional name the op); `count` is the request column whose length gives N."""

    op: str
    request: tuple[Column, ...]
    reply: tuple[Column, ...]
    flags: tuple[str, ...]
    count: str

    def bit(self, name: str) -> int:
        return 1 << self.flags.index(name)

    def request_column(self, name: str) -> Column:
        return next(c for c in self.request if c.name == name)


def _req(op: str, name: str, dtype: str, width: int, required: bool) -> Column:
    return Column(name, dtype, width, required=(op,) if required else (), optional=() if required else (op,))


def _at(op: str, optional: tuple[Column, ...]) -> tuple[Column, ...]:
    """A point query's columns: its cell and origin, then `optional`."""
    return (_req(op, "cell", "u32", 1, True), _req(op, "origin", "f64", 3, True)) + optional


def _segment(op: str, radius_required: bool, viewer: bool) -> tuple[Column, ...]:
    cols = (
        _req(op, "from_cell", "u32", 1, True),
        _req(op, "from_origin", "f64", 3, True),
        _req(op, "to_cell", "u32", 1, True),
        _req(op, "to_origin", "f64", 3, True),
        _req(op, "radius", "f64", 1, radius_required),
        _req(op, "target", "u64", 1, False),
    )
    return cols + ((_req(op, "viewer", "u64", 1, False),) if viewer else ())


#: what a reply column holds where there is no value: NaN for reals, 255 for a u8 code, else 0
_MISSING = {"f64": "NaN", "u8": "255", "u32": "0", "u64": "0"}


def _out(*columns: tuple[str, str, int]) -> tuple[Column, ...]:
    """Reply columns (name, dtype, per item), after the `flags` column every reply starts with."""
    return (Column("flags", "u32", 1, missing="0"),) + tuple(
        Column(name, dtype, width, missing=_MISSING[dtype]) for name, dtype, width in columns)


_BLOCKER = (("blocker", "u8", 1), ("blocker_id", "u64", 1))

QUERY_COLUMNS: Final[dict[str, QueryColumns]] = {
    "sight": QueryColumns(
        "sight",
        _segment("sight", False, True),
        _out(("cell", "u32", 1), ("stop", "f64", 3), ("normal", "f64", 3), *_BLOCKER),
        ("resolved", "clear", "stop given", "normal given", "blocker_id given"),
        "from_cell",
    ),
    "ray": QueryColumns(
        "ray",
        _segment("ray", True, False),
        _out(("cell", "u32", 1), ("position", "f64", 3), ("normal", "f64", 3), ("distance", "f64", 1), *_BLOCKER),
        ("resolved", "hit", "normal given", "blocker_id given"),
        "from_cell",
    ),
    "ground": QueryColumns(
        "ground",
        _at("ground", (_req("ground", "max_drop", "f64", 1, False),)),
        _out(("z", "f64", 1), ("plane", "f64", 4), ("cell", "u32", 1), ("water_depth", "f64", 1)),
        ("resolved", "found", "walkable"),
        "cell",
    ),
    "place": QueryColumns(
        "place",
        _at("place", (_req("place", "orientation", "f64", 4, False),)),
        _out(("placement_result", "u8", 1), ("cell", "u32", 1), ("origin", "f64", 3), ("orientation", "f64", 4),
             ("contact_plane", "f64", 4), ("contact_plane_cell", "u32", 1)),
        ("resolved", "ok", "contact", "on_walkable", "water_contact", "contact_plane given",
         "contact_plane_cell given"),
        "cell",
    ),
}

#: How far a given orientation's length may be from 1 (as the map form's `as_quat`).
_UNIT_TOLERANCE = 1e-3


@dataclass(slots=True)
class QueryColumnRequest:
    """A decoded column query: its op, its columns as arrays, the top-level fields of a place (the
    `mover` MoverSpec, `mode`, `slide`) and the items already known bad."""

    op: str
    n: int
    arrays: dict[str, Array]
    options: dict[str, Any] = field(default_factory=dict)
    bad: dict[int, ProtocolError] = field(default_factory=dict)

    def refuse(self, i: int, kind: str, path: str, why: str, **extra: Any) -> None:
        """Item i fails (its first refused value wins)."""
        if i not in self.bad:
            self.bad[i] = ProtocolError(kind, f"{path}: {why}", path, **extra)


def is_query_columns(msg: dict[str, Any]) -> bool:
    return msg.get("columns") is not None


def query_column_count(msg: dict[str, Any], op: str) -> int:
    """How many queries a column request holds (0 when unreadable: the decoder then refuses it)."""
    cols = msg.get("columns")
    spec = QUERY_COLUMNS[op]
    raw = cols.get(spec.count) if isinstance(cols, dict) else None
    return len(raw) // spec.request_column(spec.count).item_bytes if isinstance(raw, bytes) else 0


def _bad_ranges(req: QueryColumnRequest, lb: int) -> None:
    """A radius outside MIN_SPHERE_RADIUS .. MAX_RAY_RADIUS (for a sight 0 is the default), a max_drop below 0,
    a non-unit orientation, a start outside the key's landblock."""
    a = req.arrays
    ray = req.op == "ray"

    def bad_radius(v: np.ndarray[Any, Any]) -> np.ndarray[Any, Any]:
        out: np.ndarray[Any, Any] = ~((v >= MIN_SPHERE_RADIUS) & (v <= MAX_RAY_RADIUS))
        return out if ray else out & (v != 0.0)

    radius_range = f"be from {MIN_SPHERE_RADIUS:g} to {MAX_RAY_RADIUS:g} m" + ("" if ray else " (0: the default)")
    for name, low, must in (("radius", bad_radius, radius_range),
                            ("max_drop", lambda v: v < 0.0, "not be negative")):
        values = a.get(name)
        if values is not None:
            for i in np.flatnonzero(low(values)).tolist():
                req.refuse(i, ErrorKind.BAD_VALUE, f"columns.{name}[{i}]", f"must {must}, got {values[i]}")
    q = a.get("orientation")
    if q is not None:
        with np.errstate(invalid="ignore", over="ignore"):
            length = np.sqrt((q * q).sum(axis=1))
        given = (q != 0.0).any(axis=1)
        for i in np.flatnonzero(given & ~(np.abs(length - 1.0) <= _UNIT_TOLERANCE)).tolist():
            req.refuse(i, ErrorKind.BAD_VALUE, f"columns.orientation[{i}]",
                       f"quaternion length {length[i]:.6g} is not 1 (all zeros: the identity)")
    name = QUERY_COLUMNS[req.op].count
    cells = a[name]
    for i in np.flatnonzero(((cells >> 16) & 0xFFFF) != lb).tolist():
        owner = (int(cells[i]) >> 16) & 0xFFFF
        req.refuse(i, ErrorKind.WRONG_LANDBLOCK, f"columns.{name}[{i}]",
                   f"cell {int(cells[i]):08X} is not in landblock {lb:04X} (the key's); send it to that landblock's key",
                   landblock=owner)


def parse_query_columns(op: str, msg: dict[str, Any], lb: int,
                        read_options: Callable[[dict[str, Any]], dict[str, Any]] | None = None) -> QueryColumnRequest:
    """`{"v": 1, "columns": {...}}` (a place also `mover`, `mode`, `slide`, read by `read_options`) to a
    QueryColumnRequest; ProtocolError for anything that concerns the whole request."""
    spec = QUERY_COLUMNS[op]
    from .queries import BATCH_FIELDS  # here: service.queries imports this module


    if msg.get(op) is not None or msg.get(BATCH_FIELDS[op]) is not None:  # nil is as good as absent
        raise ProtocolError(ErrorKind.BAD_VALUE, f"give exactly one of {op}, {BATCH_FIELDS[op]} or columns")
    cols = msg.get("columns")
    if not isinstance(cols, dict):
        raise ProtocolError(ErrorKind.WRONG_TYPE, f"columns: expected a map, got {_type_name(cols)}", "columns")
    known = {c.name for c in spec.request}
    for name in cols:
        if name not in known:
            path = f"columns.{str(name)[:40]}"
            raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: not a column of {op} (columns: {', '.join(sorted(known))})",
                                path)
    given: dict[str, bytes] = {}
    for col in spec.request:
        raw = _column_bytes(cols, col, op)
        if raw is not None:
            given[col.name] = raw
    n = len(given[spec.count]) // spec.request_column(spec.count).item_bytes
    if n > MAX_BATCH:
        path = f"columns.{spec.count}"
        raise ProtocolError(ErrorKind.TOO_LARGE, f"{path}: {n} items, at most {MAX_BATCH} allowed", path)
    arrays: dict[str, Array] = {}
    for col in spec.request:
        raw_bytes = given.get(col.name)
        if raw_bytes is None:
            continue
        count = len(raw_bytes) // col.item_bytes
        if count != n:
            path = f"columns.{col.name}"
            raise ProtocolError(ErrorKind.BAD_VALUE, f"{path}: {count} items, but columns.{spec.count} has {n} "
                                "(every column holds one entry per item)", path)
        a = np.frombuffer(raw_bytes, dtype=col.np_dtype).astype(col.np_dtype.newbyteorder("="), copy=False)
        arrays[col.name] = a if col.width == 1 else a.reshape(n, col.width)
    req = QueryColumnRequest(op, n, arrays, read_options(msg) if read_options is not None else {})
    refuse_bad_reals(spec.request, arrays, n, req.bad)
    _bad_ranges(req, lb)
    return req


# -- running and encoding -----------------------------------------------------------------------
RunOne = Callable[[int, tuple[Any, ...]], Any]  # (item index, map-form item) -> the engine's answer


def _reply_arrays(spec: QueryColumns, n: int) -> dict[str, Array]:
    out: dict[str, Array] = {}
    for col in spec.reply:
        shape = (n,) if col.width == 1 else (n, col.width)
        fill = float("nan") if col.missing == "NaN" else int(col.missing)
        out[col.name] = np.full(shape, fill, dtype=col.np_dtype.newbyteorder("="))
    return out


def _blocker(out: dict[str, Array], spec: QueryColumns, i: int, b: Any, blocker_id: Callable[[int], int]) -> int:
    """Writes the blocker of row i; returns its flag bits."""
    if b is None:
        return 0
    out["blocker"][i] = BLOCKER_CODES.index(b.kind)
    bits = 0
    if b.object_id is not None:
        out["blocker_id"][i] = blocker_id(b.object_id)
        bits |= spec.bit("blocker_id given")
    return bits


def _put(out: dict[str, Array], spec: QueryColumns, i: int, answer: Any, blocker_id: Callable[[int], int]) -> None:
    """Row i of the reply from the engine's answer (what the map form encodes from the same answer)."""
    bits = spec.bit("resolved")
    op = spec.op
    if op == "sight":
        if answer.clear:
            bits |= spec.bit("clear")
        if answer.stop is not None:
            bits |= spec.bit("stop given")
            out["cell"][i] = answer.stop.cell_id if answer.cell is None else answer.cell
            out["stop"][i] = answer.stop.frame.origin.as_tuple()
        if answer.normal is not None:
            bits |= spec.bit("normal given")
            out["normal"][i] = answer.normal.as_tuple()
        bits |= _blocker(out, spec, i, answer.blocker, blocker_id)
    elif op == "ray":
        if answer.hit:
            bits |= spec.bit("hit")
        out["cell"][i] = answer.cell
        out["position"][i] = answer.position.frame.origin.as_tuple()
        out["distance"][i] = answer.distance
        if answer.normal is not None:
            bits |= spec.bit("normal given")
            out["normal"][i] = answer.normal.as_tuple()
        bits |= _blocker(out, spec, i, answer.blocker, blocker_id)
    elif op == "ground":
        if answer is not None:
            bits |= spec.bit("found")
            if answer.walkable:
                bits |= spec.bit("walkable")
            out["z"][i] = answer.z
            n = answer.plane.normal
            out["plane"][i] = (n.x, n.y, n.z, answer.plane.d)
            out["cell"][i] = answer.cell
            out["water_depth"][i] = answer.water_depth
    else:
        out["placement_result"][i] = PLACEMENT_CODES.index(answer.placement_result)
        for flag, value in (("ok", answer.ok), ("contact", answer.contact), ("on_walkable", answer.on_walkable),
                            ("water_contact", answer.water_contact)):
            if value:
                bits |= spec.bit(flag)
        if answer.position is not None:
            out["cell"][i] = answer.position.cell_id
            out["origin"][i] = answer.position.frame.origin.as_tuple()
            out["orientation"][i] = answer.position.frame.orientation.as_tuple()
        if answer.contact_plane is not None:
            bits |= spec.bit("contact_plane given")
            n = answer.contact_plane.normal
            out["contact_plane"][i] = (n.x, n.y, n.z, answer.contact_plane.d)
        if answer.contact_plane_cell is not None:
            bits |= spec.bit("contact_plane_cell given")
            out["contact_plane_cell"][i] = answer.contact_plane_cell
    out["flags"][i] = bits


def run_query_columns(req: QueryColumnRequest, items: Callable[[int], tuple[Any, ...]], run_one: RunOne,
                      to_error: Callable[[Exception, int], ProtocolError],
                      blocker_id: Callable[[int], int]) -> dict[str, Any]:
    """Answer every item not already refused: `items(i)` is item i as the map form decodes it, `run_one`
    answers it on the engine, `to_error` turns what it raised into the item's error. Returns the reply
    map `{"v", "n", "columns", "errors"}`."""
    spec = QUERY_COLUMNS[req.op]
    out = _reply_arrays(spec, req.n)
    errors: list[dict[str, Any]] = []
    for i in range(req.n):
        err = req.bad.get(i)
        if err is None:
            try:
                _put(out, spec, i, run_one(i, items(i)), blocker_id)
                continue
            except Exception as e:
                err = to_error(e, i)
        errors.append({"index": i, "error": err.to_wire()})
    return {"v": PROTOCOL_VERSION, "n": req.n, "columns": pack_columns(spec.reply, out), "errors": errors}
