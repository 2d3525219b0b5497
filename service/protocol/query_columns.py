"""The column form of the queries, read and answered.

A column query carries N queries of one op (sight, ray, ground, place, path)
as packed little-endian arrays (msgpack `bin`), as a column move batch does
(service/protocol/columns.py), and its reply carries the answers the same way
(docs/protocol.md, "Query columns", "Path columns"). The columns themselves
are declared with each query in service/protocol/queries.py; this module
reads a request's columns (`parse_query_columns`) and writes the answers
(`run_query_columns`).

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
from typing import Any

import numpy as np

from engine.limits import MAX_RAY_RADIUS, MAX_WANDER_RADIUS, MIN_SPHERE_RADIUS, UNIT_TOLERANCE

from service.protocol.column_request import _column_bytes, _type_name, refuse_bad_reals
from service.protocol.columns import pack_columns
from service.protocol.errors import ProtocolError
from service.protocol import BLOCKER_CODES, PLACEMENT_CODES, QUERIES, QUERY_COLUMNS, REASON_CODES, QueryColumns, read_options
from service.protocol.wire import PROTOCOL_VERSION, ErrorKind

__all__ = [
    "QueryColumnRequest",
    "is_query_columns",
    "query_column_count",
    "parse_query_columns",
    "run_query_columns",
]

Array = np.ndarray[Any, Any]

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


#: (column, the values out of range, what they must be) of each op: the ranges its map form's fields hold
_RANGES: dict[str, tuple[tuple[str, Callable[[Array], Array], str], ...]] = {
    "sight": (("radius", lambda v: ~((v >= MIN_SPHERE_RADIUS) & (v <= MAX_RAY_RADIUS)) & (v != 0.0),
               f"be from {MIN_SPHERE_RADIUS:g} to {MAX_RAY_RADIUS:g} m (0: the default)"),),
    "ray": (("radius", lambda v: ~((v >= MIN_SPHERE_RADIUS) & (v <= MAX_RAY_RADIUS)),
             f"be from {MIN_SPHERE_RADIUS:g} to {MAX_RAY_RADIUS:g} m"),),
    "ground": (("max_drop", lambda v: v < 0.0, "not be negative"),),
    "random_point": (("radius", lambda v: ~((v > 0.0) & (v <= MAX_WANDER_RADIUS)),
                      f"be above 0 and at most {MAX_WANDER_RADIUS:,.0f} m"),),
}


def _bad_ranges(req: QueryColumnRequest, lb: int) -> None:
    """A value outside its range (_RANGES), a non-unit orientation, a start outside the key's landblock."""
    a = req.arrays
    for name, out_of_range, must in _RANGES.get(req.op, ()):
        values = a.get(name)
        if values is not None:
            for i in np.flatnonzero(out_of_range(values)).tolist():
                req.refuse(i, ErrorKind.BAD_VALUE, f"columns.{name}[{i}]", f"must {must}, got {values[i]}")
    q = a.get("orientation")
    if q is not None:
        with np.errstate(invalid="ignore", over="ignore"):
            length = np.sqrt((q * q).sum(axis=1))
        given = (q != 0.0).any(axis=1)
        for i in np.flatnonzero(given & ~(np.abs(length - 1.0) <= UNIT_TOLERANCE)).tolist():
            req.refuse(i, ErrorKind.BAD_VALUE, f"columns.orientation[{i}]",
                       f"quaternion length {length[i]:.6g} is not 1 (all zeros: the identity)")
    name = QUERY_COLUMNS[req.op].count
    cells = a[name]
    for i in np.flatnonzero(((cells >> 16) & 0xFFFF) != lb).tolist():
        owner = (int(cells[i]) >> 16) & 0xFFFF
        req.refuse(i, ErrorKind.WRONG_LANDBLOCK, f"columns.{name}[{i}]",
                   f"cell {int(cells[i]):08X} is not in landblock {lb:04X} (the key's); send it to that landblock's key",
                   landblock=owner)


def parse_query_columns(op: str, msg: dict[str, Any], lb: int) -> QueryColumnRequest:
    """`{"v": 1, "columns": {...}}` (and the op's top-level options: a place's `mover`, `mode`, `slide`) to
    a QueryColumnRequest; ProtocolError for anything that concerns the whole request."""
    spec = QUERY_COLUMNS[op]
    kind = QUERIES[op]
    if msg.get(op) is not None or msg.get(kind.batch) is not None:  # nil is as good as absent
        raise ProtocolError(ErrorKind.BAD_VALUE, f"give exactly one of {op}, {kind.batch} or columns")
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
    if n > kind.max_batch:
        path = f"columns.{spec.count}"
        raise ProtocolError(ErrorKind.TOO_LARGE, f"{path}: {n} items, at most {kind.max_batch} allowed", path)
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
    req = QueryColumnRequest(op, n, arrays, read_options(kind, msg))
    refuse_bad_reals(spec.request, arrays, n, req.bad)
    _bad_ranges(req, lb)
    return req


# -- running and encoding -----------------------------------------------------------------------
RunOne = Callable[[int, tuple[Any, ...]], Any]  # (item index, map-form item) -> the engine's answer


def _reply_arrays(spec: QueryColumns, n: int) -> dict[str, Array]:
    return {col.name: col.missing_rows(n) for col in spec.reply}


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
    elif op in ("path", "random_point"):
        if answer.found:
            bits |= spec.bit("found")
        else:
            out["reason"][i] = REASON_CODES.index(answer.reason)
        out["length"][i] = answer.length
        out["expanded"][i] = answer.expanded
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


def _lists(spec: QueryColumns, out: dict[str, Array], answers: list[Any]) -> dict[str, Array]:
    """The ragged columns (a path's waypoints): every answered item's list, item after item, each item's
    share found by its `waypoint_start` and `waypoint_count`."""
    if not spec.ragged:
        return {}
    cells: list[int] = []
    origins: list[tuple[float, float, float]] = []
    for i, answer in enumerate(answers):
        if answer is None:
            continue
        out["waypoint_start"][i] = len(cells)
        out["waypoint_count"][i] = len(answer.waypoints)
        for w in answer.waypoints:
            cells.append(w.cell_id)
            origins.append(w.frame.origin.as_tuple())
    cell_col, origin_col = spec.ragged
    return {cell_col.name: np.asarray(cells, dtype=cell_col.np_dtype),
            origin_col.name: np.asarray(origins, dtype=origin_col.np_dtype).reshape(len(origins), 3)}


def run_query_columns(req: QueryColumnRequest, items: Callable[[int], tuple[Any, ...]], run_one: RunOne,
                      to_error: Callable[[Exception, int], ProtocolError],
                      blocker_id: Callable[[int], int]) -> dict[str, Any]:
    """Answer every item not already refused: `items(i)` is item i as the map form decodes it, `run_one`
    answers it on the engine, `to_error` turns what it raised into the item's error. Returns the reply
    map `{"v", "n", "columns", "errors"}`."""
    spec = QUERY_COLUMNS[req.op]
    out = _reply_arrays(spec, req.n)
    errors: list[dict[str, Any]] = []
    answers: list[Any] = [None] * req.n
    for i in range(req.n):
        err = req.bad.get(i)
        if err is None:
            try:
                answers[i] = answer = run_one(i, items(i))
                _put(out, spec, i, answer, blocker_id)
                continue
            except Exception as e:
                err = to_error(e, i)
        errors.append({"index": i, "error": err.to_wire()})
    ragged = _lists(spec, out, answers)  # fills the items' list starts and counts in `out` first
    columns = pack_columns(spec.reply, out)
    columns.update(pack_columns(spec.ragged, ragged))
    return {"v": PROTOCOL_VERSION, "n": req.n, "columns": columns, "errors": errors}
