"""Running a column request on the core: moves in, result columns out.

The column twin of `ServiceCore.moves` / `ServiceCore.push` (the same
per-move steps: the engine call, the hand-over when a move leaves the
instance's landblocks, the publication), with the moves run by the
engine's batch entry point (engine.world.batch.run_batch): one compiled
loop writes every result into two flat lists (reals and integers) that
become the reply's arrays in one numpy call each, and no map is built per
move. Each mover's `seq` is the engine's count (Mover.seq), written into
the rows beside the results, so nothing here touches a mover per item
unless it failed, is published or leaves. Runs on the engine thread, with
the engine lock held, as the map form.
"""

from __future__ import annotations

import logging
from itertools import repeat
from operator import is_not
from dataclasses import dataclass, field
from time import monotonic, perf_counter
from typing import TYPE_CHECKING, Any

import numpy as np

from engine import Mover, MoveResult
from engine.world.batch import (
    MOTION,
    MOVER_STATE_BYTES,
    OFFSET,
    TO,
    BatchRows,
    append_missing,
    append_row,
    run_batch,
)

from service.protocol.codec import pack_state
from service.protocol.column_frames import REPLY_NAMES, rows_message
from service.protocol.column_request import ColumnRequest
from service.protocol.columns import REPLY_COLUMNS, REQUEST_COLUMNS, Flag, pack_columns
from service.engine_errors import to_protocol_error
from service.protocol.errors import ProtocolError
from service.protocol.frames import pack
from service.protocol.requests import ItemError
from service.protocol.wire import ErrorKind

if TYPE_CHECKING:
    from service.core import ServiceCore

__all__ = ["ColumnResults", "run_columns", "push_columns", "reply_message", "publication_message"]

log = logging.getLogger("acphys.service")

_KIND = {"offset": OFFSET, "to": TO, "motion": MOTION}
_GONE = bytes(MOVER_STATE_BYTES)
_LE_U64 = np.dtype("<u8")
_LE_F64 = np.dtype("<f8")
_MAIN_COLUMN = {"offset": "offset", "to": "to_origin", "motion": "motion"}
_COLLIDE_COUNT_AT = REPLY_NAMES.index("collide_count")
_FLAGS_AT = REPLY_NAMES.index("flags")


@dataclass(slots=True)
class ColumnResults:
    """One request's results: the engine's rows (engine.world.batch), and the items that failed."""

    n: int
    rows: BatchRows = field(default_factory=BatchRows)
    #: the wire ids of the movers each row collided with, in row order, and how many a row has (None:
    #: no row collided with anything)
    collide_ids: list[int] = field(default_factory=list)
    collide_counts: list[int] | None = None
    #: (index, mover id, error) of every item that failed, in index order
    errors: list[tuple[int, int, ProtocolError]] = field(default_factory=list)
    #: items forwarded to another instance's push key (fire-and-forget only); they have no row values
    forwarded: int = 0
    #: items before this index have their error, forward or publication settled
    settled: int = 0
    #: States to publish as they settle: one put each ("each"), or gathered into `packed` ("batch")
    publish_each: bool = False
    gather: bool = False
    packed: list[bytes] = field(default_factory=list)
    #: items before this index are in the state log (service/persistence/journal_records.py), when there is one
    journaled: int = 0


def run_columns(core: ServiceCore, req: ColumnRequest, received: float, *,
                forward: bool = False) -> tuple[ColumnResults, list[bytes]]:
    """Every item of `req` in order, run by the engine's batch entry point; the results and, for
    `publish: "batch"`, the packed States to put on P/states (empty otherwise: "each" and "columns"
    are published here). `forward`: a fire-and-forget request, whose items for movers handed over
    meanwhile go on to the new owner's push key."""
    bus = core.bus
    arrays = req.arrays
    ids: list[int] = req.ids if req.ids is not None else arrays["id"].tolist()
    movers = core.engine_movers_of(ids)
    for i in req.bad:  # a refused item does not run
        movers[i] = None
    out = ColumnResults(req.n)
    out.publish_each = req.publish == "each" and bus.states_watched()
    out.gather = req.publish == "batch" and bus.batch_watched()
    rows = out.rows
    if core.log is not None:
        rows.states = core.log.row_states()  # each row's mover as it stands after its move, for the state log
    kind = _KIND[req.kind]
    # the real columns as their little-endian float64 bytes, which run_batch reads in place: the map form's
    # values exactly (msgpack float64), with no Python float made per value
    vectors = _reals(arrays[_MAIN_COLUMN[req.kind]])
    cells = arrays["to_cell"].tolist() if "to_cell" in arrays else None
    orientations = _reals(arrays["to_orientation"]) if "to_orientation" in arrays else None
    velocities = _reals(arrays["velocity"]) if "velocity" in arrays else None
    dts = _reals(arrays["dt"]) if "dt" in arrays else None
    ownership = core.ownership
    stop_if = None if ownership.everything else (lambda lb: not ownership.owns(lb))
    landscape = core.world.landscape
    started, since = perf_counter(), monotonic() - received
    n = req.n
    i = run_batch(landscape, movers, kind, vectors, rows, cells=cells, orientations=orientations,
                  velocities=velocities, dts=dts, stop_if=stop_if)
    if i == n and rows.resolved == n and not (out.publish_each or out.gather):
        out.settled = n  # the usual run: every item ran in one go and resolved, and nothing is published
    else:
        while i < n:  # item i left this instance's landblocks
            _leave(core, req, out, movers, ids, i, forward)
            i = run_batch(landscape, movers, kind, vectors, rows, start=i + 1, cells=cells,
                          orientations=orientations, velocities=velocities, dts=dts, stop_if=stop_if)
        _settle(core, req, out, ids, forward, n)
    if core.log is not None:
        _journal(core, req, out, req.n)
        core.commit()
    if out.errors:
        out.errors.sort(key=lambda e: e[0])
    if rows.collide_ids:  # a row collided: its engine ids become wire ids
        _translate_collisions(core, out)
    # each move's latency, from the request's arrival to its result, is its finishing time shifted by
    # `since - started`: the stats keep the engine's list and the shift, and add them up when asked
    core.batch_done(since - started, rows.finished_at.getvalue(), rows.engine_seconds.getvalue())
    if req.publish == "columns" and len(out.errors) + out.forwarded < req.n and core.bus.columns_watched():
        core.bus.publish_columns(publication_message(out, req))
    return out, out.packed


def _reals(a: np.ndarray[Any, Any]) -> bytes:
    """A real column's values in item order as little-endian float64 bytes (engine.world.batch.Reals): a
    request's column is that already (parse_column_request), so this is one copy of its bytes."""
    return a.tobytes() if a.dtype == _LE_F64 else np.ascontiguousarray(a, _LE_F64).tobytes()


def _published(core: ServiceCore, out: ColumnResults, mover_id: int, r: MoveResult) -> None:
    """The State of a settled result, put (or gathered) in item order: before anything forwarded after it."""
    if out.publish_each or out.gather:
        state = pack_state(mover_id, r.seq, r, core.collide_ids(r))
        if out.publish_each:
            core.publish_state(mover_id, state)
        else:
            out.packed.append(state)


def _leave(core: ServiceCore, req: ColumnRequest, out: ColumnResults, movers: list[Mover | None],
           ids: list[int], i: int, forward: bool) -> None:
    """Item i's move ended outside this instance: hand the mover over (its row is then the result), or
    take the move back and fail the item. After a hand-over, later items of that mover are not run here."""
    _settle(core, req, out, ids, forward, i)
    rec = core.movers.get(ids[i])
    result = out.rows.results[i]
    assert rec is not None and result is not None
    lb = (result.position.cell_id >> 16) & 0xFFFF
    # published "each": by the new owner, whose next States follow it on the same session
    state = pack_state(rec.id, result.seq, result, core.collide_ids(result)) if out.publish_each else None
    undo = out.rows.undo
    assert undo is not None  # run_batch keeps it for the item it stopped at (the move counted: undo uncounts)
    if core.log is not None:
        _journal(core, req, out, i)  # the moves before this one, then (in _hand_over) the hand-over
    try:
        core.hand_over(rec, lb, state, undo)
    except ProtocolError as e:
        out.rows.results[i] = None
        out.errors.append((i, rec.id, e))
        append_missing(out.rows)
    else:
        append_row(out.rows, result)
        if out.rows.states is not None:
            out.rows.states.write(_GONE)  # the mover went with the hand-over: not this instance's to log
        if out.gather:
            out.packed.append(pack_state(rec.id, result.seq, result, core.collide_ids(result)))
    out.settled = i + 1
    out.journaled = i + 1
    if core.movers.get(rec.id) is None:  # handed over: later items of that mover are not run here
        for j in range(i + 1, len(ids)):
            if movers[j] is rec.mover:
                movers[j] = None


def _journal(core: ServiceCore, req: ColumnRequest, out: ColumnResults, upto: int) -> None:
    """Items `out.journaled` .. `upto - 1` that resolved go to the state log as one MOVES record: their ids,
    seqs (the rows' own) and the states the engine wrote beside their rows."""
    lo = out.journaled
    if upto <= lo:
        return
    out.journaled = upto
    log, rows = core.log, out.rows
    states = rows.states
    assert log is not None and states is not None
    seqs = np.frombuffer(rows.seq.getvalue(), dtype="<u8")[lo:upto]
    ids = req.arrays["id"][lo:upto]
    raw = states.getvalue()
    if lo or len(raw) != upto * MOVER_STATE_BYTES:
        raw = raw[lo * MOVER_STATE_BYTES:upto * MOVER_STATE_BYTES]
    if not seqs.all():  # some did not resolve (a resolved move's seq is at least 1): their rows are left out
        resolved = seqs != 0
        raw = np.frombuffer(raw, dtype=f"V{MOVER_STATE_BYTES}")[resolved].tobytes()
        log.moved_rows(np.ascontiguousarray(ids[resolved], "<u8").tobytes(), seqs[resolved].tobytes(), raw,
                       int(resolved.sum()))
    else:
        # a request's id column is little-endian uint64 already (parse_column_request), its slices contiguous
        id_bytes = ids.tobytes() if ids.dtype == _LE_U64 else np.ascontiguousarray(ids, "<u8").tobytes()
        log.moved_rows(id_bytes, seqs.tobytes(), raw, len(seqs))


def _settle(core: ServiceCore, req: ColumnRequest, out: ColumnResults, ids: list[int], forward: bool,
            upto: int) -> None:
    """Items `out.settled` .. `upto - 1` in order: the errors of items that did not run (refused values,
    ids not held here, engine refusals), forwarding after a hand-over, and the States to publish."""
    results = out.rows.results
    publishing = out.publish_each or out.gather
    first = out.settled
    out.settled = upto
    # the usual run, every item resolved and nothing to publish, has nothing to settle (`is not`, not
    # `None in`: that would call MoveResult's __eq__ once per item)
    if not publishing and all(map(is_not, results[first:upto], repeat(None))):
        return
    engine_errors: dict[int, Exception] | None = None
    for i in range(first, upto):
        r = results[i]
        if r is not None:
            if publishing:
                _published(core, out, ids[i], r)
            continue
        if engine_errors is None:
            engine_errors = dict(out.rows.errors)
        _unresolved(core, req, out, ids[i], i, engine_errors, forward)


def _unresolved(core: ServiceCore, req: ColumnRequest, out: ColumnResults, mid: int, i: int,
                engine_errors: dict[int, Exception], forward: bool) -> None:
    """Item i did not run: its error (a refused value, the engine's refusal, a mover not held here), or,
    for a push whose mover was handed over meanwhile, the item forwarded to the new owner."""
    err = req.bad.get(i)
    if err is None:
        exc = engine_errors.get(i)
        if exc is not None:
            err = to_protocol_error(exc, f"columns.{_MAIN_COLUMN[req.kind]}[{i}]")
            if err.kind == ErrorKind.INTERNAL:
                log.error("engine failed on move of %X", mid, exc_info=exc)
        elif forward and (fwd := core.forwarded_to(mid)) is not None:
            # keep the mover's order: everything sent here after the hand-over follows it
            core.bus.forward_columns(fwd, _one_row_message(req, i))
            out.forwarded += 1
            return
        else:
            err = _not_held(core, mid, i)
    out.errors.append((i, mid, err))


def _not_held(core: ServiceCore, mover_id: int, i: int) -> ProtocolError:
    """Why item i's mover is not here: `moved` or `unknown_mover`."""
    try:
        core.mover_record(mover_id, f"columns.id[{i}]")
    except ProtocolError as e:
        return e
    raise AssertionError(f"mover {mover_id:X} is held but its item did not run")


def _translate_collisions(core: ServiceCore, out: ColumnResults) -> None:
    """The engine's collided-object ids as wire ids (objects that are not movers here are left out), and
    each row's count of them."""
    counts: list[int] = []
    wire: list[int] = []
    for r in out.rows.results:
        if r is None or not r.collide_objects:
            counts.append(0)
            continue
        got = core.collide_ids(r)
        counts.append(len(got))
        wire.extend(got)
    out.collide_ids, out.collide_counts = wire, counts


def _one_row_message(req: ColumnRequest, i: int) -> bytes:
    """Item `i` of `req` as a column push of its own (to forward it after a hand-over)."""
    cols = pack_columns(REQUEST_COLUMNS, {name: a[i:i + 1] for name, a in req.arrays.items()})
    return pack({"kind": req.kind, "columns": cols, "publish": req.publish})


def _reply_columns(out: ColumnResults) -> list[bytes]:
    """The reply's columns (REPLY_NAMES) as the engine wrote them (its result columns are the wire's,
    engine.world.rows), with the collided movers' counts of wire ids when a row collided with anything,
    and their wire ids."""
    cols = list(out.rows.columns().values())
    if out.collide_counts is not None:
        cols[_COLLIDE_COUNT_AT] = np.array(out.collide_counts, dtype="<u4").tobytes()
    cols.append(np.array(out.collide_ids, dtype="<u8").tobytes() if out.collide_ids else b"")
    return cols


def _error_entries(out: ColumnResults) -> list[dict[str, Any]]:
    return [{"index": i, "id": mid, "error": e.to_wire()} for i, mid, e in out.errors]


def reply_message(out: ColumnResults) -> bytes:
    """`{"v": 1, "n", "columns", "errors"}`: the reply to a column query."""
    return rows_message(out.n, out.rows.count, _reply_columns(out), _error_entries(out))


def publication_message(out: ColumnResults, req: ColumnRequest) -> bytes:
    """`{"v": 1, "n", "columns"}` on P/state_columns: the rows of the items that resolved, with `id`."""
    n = out.rows.count
    raw = _reply_columns(out)
    arrays = [np.frombuffer(data, dtype=c.np_dtype).reshape((n, c.width) if c.width > 1 else n)
              for c, data in zip(REPLY_COLUMNS, raw)]
    keep = (arrays[_FLAGS_AT] & Flag.RESOLVED) != 0
    kept = [np.ascontiguousarray(req.arrays["id"][keep], dtype="<u8").tobytes()]
    kept += (np.ascontiguousarray(a[keep], dtype=c.np_dtype).tobytes() for c, a in zip(REPLY_COLUMNS, arrays))
    kept.append(raw[-1])
    count = int(keep.sum())
    return rows_message(count, count, kept, publication=True)


def push_columns(core: ServiceCore, req: ColumnRequest, received: float) -> None:
    """Fire-and-forget: run, publish, and put each failed item's error on its object's error key."""
    out, packed = run_columns(core, req, received, forward=True)
    for _i, mid, err in out.errors:
        core.stats.error(err.kind)
        core.bus.publish_error(mid, ItemError(err, mid).to_wire(), mid in core.movers)
    if packed:
        core.bus.publish_batch(packed)

