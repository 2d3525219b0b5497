"""Running a column request on the core: moves in, result columns out.

The column twin of `ServiceCore.moves` / `ServiceCore.push` (the same
per-move steps: the engine call, `seq`, the hand-over when a move leaves
the instance's landblocks, the publication), but no map is built per
move: each result's values are appended to two flat lists (reals and
integers) that become the reply's arrays in one numpy call each.
Runs on the engine thread, with the engine lock held, as the map form.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from time import monotonic, perf_counter
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from engine.geometry import Position, Quat, Vec3
from engine.world.types import MoveResult

from .codec import pack_state
from .column_request import ColumnRequest
from .columns import (
    FAILED_STATE,
    PUBLICATION_ID,
    REPLY_COLUMNS,
    REQUEST_COLUMNS,
    TRANSIENT_FLAGS,
    TRANSITION_CODE,
    Flag,
    pack_columns,
)
from .engine_errors import to_protocol_error
from .errors import ProtocolError
from .frames import pack
from .requests import ItemError
from .wire import ErrorKind

if TYPE_CHECKING:
    from .core import ServiceCore

__all__ = ["ColumnBus", "ColumnResults", "run_columns", "push_columns", "reply_message", "publication_message"]

log = logging.getLogger("acphys.service")

_NAN = float("nan")
#: the reals of one row, in this order: origin 3, orientation 4, contact_plane 4, collision_normal 3, sliding_normal 3
_REALS = 17
_NO_REALS = (_NAN,) * _REALS
_NO_PLANE = (_NAN,) * 4
_NO_VEC = (_NAN,) * 3
_NO_IDS: list[int] = []
#: the integers of one row: seq, cell, flags, transition_state, frames_stationary_fall, contact_plane_cell,
#: collide_count
_INTS = 7
_NO_INTS = (0, 0, 0, FAILED_STATE, 255, 0, 0)
_TRANSIENT_BIT = {name: 1 << (Flag.TRANSIENT_SHIFT + i) for i, name in enumerate(TRANSIENT_FLAGS)}
_TRANSIENT_BITS: dict[tuple[str, ...], int] = {}
_CODE = TRANSITION_CODE
#: the flags of (ok, contact, on_walkable, water_contact), with RESOLVED
_BASE_FLAGS = {(ok, c, w, wc): Flag.RESOLVED | (Flag.OK if ok else 0) | (Flag.CONTACT if c else 0)
               | (Flag.ON_WALKABLE if w else 0) | (Flag.WATER_CONTACT if wc else 0)
               for ok in (False, True) for c in (False, True) for w in (False, True) for wc in (False, True)}


class ColumnBus(Protocol):
    """What the column form needs from the bus beyond `BusPort` (service.node implements it)."""

    def columns_watched(self) -> bool:
        """Whether anyone subscribes to P/state_columns now."""
        ...

    def publish_columns(self, message: bytes) -> None:
        """Put a columnar publication (a whole message) on P/state_columns."""
        ...

    def forward_columns(self, lb: int, message: bytes) -> None:
        """Put a column push (a whole message) on `lb`'s push key."""
        ...


@dataclass(slots=True)
class ColumnResults:
    """One request's results, row by row in flat lists (see _REALS / _INTS), and its failed items."""

    n: int
    reals: list[float] = field(default_factory=list)
    ints: list[int] = field(default_factory=list)
    collide_ids: list[int] = field(default_factory=list)
    #: (index, mover id, error) of every item that failed, in index order
    errors: list[tuple[int, int, ProtocolError]] = field(default_factory=list)
    #: the ids of the rows, for the columnar publication
    ids: list[int] = field(default_factory=list)
    #: items forwarded to another instance's push key (fire-and-forget only); they have no row values
    forwarded: int = 0


def _transient_bits(names: list[str]) -> int:
    key = tuple(names)
    bits = _TRANSIENT_BITS.get(key)
    if bits is None:
        bits = 0
        for name in names:
            bits |= _TRANSIENT_BIT.get(name, 0)
        if len(_TRANSIENT_BITS) < 256:
            _TRANSIENT_BITS[key] = bits
    return bits


def _add_row(out: ColumnResults, seq: int, r: MoveResult, collide: list[int]) -> None:
    """Append one result's values (the State's fields, as columns)."""
    pos = r.position
    frame = pos.frame
    o, q = frame.origin, frame.orientation
    cp, cn, sn, cpc, fsf = r.contact_plane, r.collision_normal, r.sliding_normal, r.contact_plane_cell, \
        r.frames_stationary_fall
    flags = _BASE_FLAGS[r.ok, r.contact, r.on_walkable, r.water_contact] | _transient_bits(r.transient_state)
    if cp is None:
        plane = _NO_PLANE
    else:
        flags |= Flag.HAS_CONTACT_PLANE
        n = cp.normal
        plane = (n.x, n.y, n.z, cp.d)
    if cn is None:
        coll = _NO_VEC
    else:
        flags |= Flag.HAS_COLLISION_NORMAL
        coll = (cn.x, cn.y, cn.z)
    if sn is None:
        slide = _NO_VEC
    else:
        flags |= Flag.HAS_SLIDING_NORMAL
        slide = (sn.x, sn.y, sn.z)
    if cpc is None:
        cpc = 0
    else:
        flags |= Flag.HAS_CONTACT_PLANE_CELL
    if fsf is None:
        fsf = 255
    else:
        flags |= Flag.HAS_FRAMES_STATIONARY_FALL
    out.reals.extend((o.x, o.y, o.z, q.w, q.x, q.y, q.z, *plane, *coll, *slide))
    out.ints.extend((seq, pos.cell_id, flags, _CODE.get(r.transition_state, FAILED_STATE), fsf, cpc, len(collide)))
    if collide:
        out.collide_ids.extend(collide)


def _fail(out: ColumnResults, index: int, mover_id: int, err: ProtocolError) -> None:
    out.errors.append((index, mover_id, err))
    out.reals.extend(_NO_REALS)
    out.ints.extend(_NO_INTS)


def run_columns(core: ServiceCore, req: ColumnRequest, received: float, *,
                forward: bool = False) -> tuple[ColumnResults, list[bytes]]:
    """Every item of `req` in order; the results and, for `publish: "batch"`, the packed States to put on
    P/states (empty otherwise: "each" and "columns" are published here). `forward`: a fire-and-forget
    request, whose items for movers handed over meanwhile go on to the new owner's push key."""
    bus = core.bus
    cbus: ColumnBus = bus  # type: ignore[assignment]  # the node implements both
    world, movers, owns = core.world, core.movers, core.ownership.owns
    everything = core.ownership.everything
    kind, n, arrays = req.kind, req.n, req.arrays
    ids: list[int] = arrays["id"].tolist()
    # the kind's vectors as lists of Python floats: the map form's values exactly (msgpack float64)
    main = arrays["offset" if kind == "offset" else "to_origin" if kind == "to" else "motion"].tolist()
    cells = arrays["to_cell"].tolist() if "to_cell" in arrays else None
    quats = arrays["to_orientation"].tolist() if "to_orientation" in arrays else None
    dts = arrays["dt"].tolist() if "dt" in arrays else None
    vels = arrays["velocity"].tolist() if "velocity" in arrays else None
    main_name = "offset" if kind == "offset" else "to_origin" if kind == "to" else "motion"
    each = req.publish == "each" and bus.states_watched()
    collect = req.publish == "batch" and bus.batch_watched()
    packed: list[bytes] = []
    out = ColumnResults(n)
    latency: list[float] = []
    engine: list[float] = []
    bad = req.bad
    ids_out = out.ids
    for i in range(n):
        mid = ids[i]
        if bad and i in bad:
            _fail(out, i, mid, bad[i])
            continue
        rec = movers.get(mid)
        if rec is None:
            if forward:
                fwd = core.forwarded_to(mid)
                if fwd is not None:
                    # keep the mover's order: everything sent here after the hand-over follows it
                    cbus.forward_columns(fwd, _one_row_message(req, i))
                    out.reals.extend(_NO_REALS)
                    out.ints.extend(_NO_INTS)
                    out.forwarded += 1
                    continue
            try:
                core.mover_record(mid, f"columns.id[{i}]")
            except ProtocolError as e:
                _fail(out, i, mid, e)
                continue
        assert rec is not None
        pos = rec.last.position
        t0 = perf_counter()
        try:
            if kind == "offset":
                v = main[i]
                result = world.move(rec.engine_id, pos.moved(Vec3(v[0], v[1], v[2])),
                                    None if vels is None else Vec3(*vels[i]))
            elif kind == "to":
                v = main[i]
                cell = cells[i] if cells is not None and cells[i] != 0 else pos.cell_id
                q = quats[i] if quats is not None else None
                quat = Quat(*q) if q is not None and (q[0] or q[1] or q[2] or q[3]) else pos.frame.orientation
                result = world.move(rec.engine_id, Position.at(cell, Vec3(v[0], v[1], v[2]), quat),
                                    None if vels is None else Vec3(*vels[i]))
            else:
                assert dts is not None
                v = main[i]
                result = world.step(rec.engine_id, Vec3(v[0], v[1], v[2]), dts[i])
        except Exception as e:
            err = to_protocol_error(e, f"columns.{main_name}[{i}]")
            if err.kind == ErrorKind.INTERNAL:
                log.exception("engine failed on move of %X", mid)
            _fail(out, i, mid, err)
            continue
        t1 = perf_counter()
        prev, prev_seq = rec.last, rec.seq
        seq = rec.seq = prev_seq + 1
        rec.last = result
        collide = core.collide_ids(result) if result.collide_objects else _NO_IDS
        if not everything:
            lb = (result.position.cell_id >> 16) & 0xFFFF
            if not owns(lb):
                try:
                    core.hand_over(rec, prev, prev_seq, lb)
                except ProtocolError as e:
                    _fail(out, i, mid, e)
                    continue
        engine.append(t1 - t0)
        latency.append(monotonic() - received)
        _add_row(out, seq, result, collide)
        ids_out.append(mid)
        if each or collect:
            state = pack_state(mid, seq, result, collide)
            if each:
                bus.publish_state(mid, state)
            else:
                packed.append(state)
    core.moves_done(latency, engine)
    if req.publish == "columns" and out.ids and cbus.columns_watched():
        cbus.publish_columns(publication_message(out))
    return out, packed


def _one_row_message(req: ColumnRequest, i: int) -> bytes:
    """Item `i` of `req` as a column push of its own (to forward it after a hand-over)."""
    cols = pack_columns(REQUEST_COLUMNS, {name: a[i:i + 1] for name, a in req.arrays.items()})
    return pack({"kind": req.kind, "columns": cols, "publish": req.publish})


def _arrays(out: ColumnResults) -> dict[str, np.ndarray[Any, Any]]:
    """The reply's columns from the flat lists (rows of failed items hold the missing values)."""
    rows = len(out.ints) // _INTS
    reals = np.array(out.reals, dtype="<f8").reshape(rows, _REALS)
    ints = np.array(out.ints, dtype=np.uint64).reshape(rows, _INTS)
    return {
        "seq": ints[:, 0], "cell": ints[:, 1], "flags": ints[:, 2], "transition_state": ints[:, 3],
        "frames_stationary_fall": ints[:, 4], "contact_plane_cell": ints[:, 5], "collide_count": ints[:, 6],
        "origin": reals[:, 0:3], "orientation": reals[:, 3:7], "contact_plane": reals[:, 7:11],
        "collision_normal": reals[:, 11:14], "sliding_normal": reals[:, 14:17],
    }


def _collide_bytes(ids: list[int]) -> bytes:
    return np.array(ids, dtype="<u8").tobytes()


def _error_entries(out: ColumnResults) -> list[dict[str, Any]]:
    return [{"index": i, "id": mid, "error": e.to_wire()} for i, mid, e in out.errors]


def reply_message(out: ColumnResults) -> bytes:
    """`{"v": 1, "n", "columns", "errors"}`: the reply to a column query."""
    cols = pack_columns(REPLY_COLUMNS, _arrays(out))
    cols["collide_ids"] = _collide_bytes(out.collide_ids)
    return pack({"n": out.n, "columns": cols, "errors": _error_entries(out)})


def publication_message(out: ColumnResults) -> bytes:
    """`{"v": 1, "n", "columns"}` on P/state_columns: the rows of the items that resolved, with `id`."""
    arrays = _arrays(out)
    keep = (arrays["flags"] & Flag.RESOLVED) != 0
    cols = {PUBLICATION_ID.name: np.array(out.ids, dtype="<u8").tobytes()}
    cols.update(pack_columns(REPLY_COLUMNS, {k: a[keep] for k, a in arrays.items()}))
    cols["collide_ids"] = _collide_bytes(out.collide_ids)
    return pack({"n": len(out.ids), "columns": cols})


def push_columns(core: ServiceCore, req: ColumnRequest, received: float) -> None:
    """Fire-and-forget: run, publish, and put each failed item's error on its object's error key."""
    out, packed = run_columns(core, req, received, forward=True)
    for _i, mid, err in out.errors:
        core.stats.error(err.kind)
        core.bus.publish_error(mid, ItemError(err, mid).to_wire())
    if packed:
        core.bus.publish_batch(packed)

