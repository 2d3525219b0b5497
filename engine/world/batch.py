"""Many moves in one call, results as flat rows: the engine's batch entry point.

A caller holding many moves of one kind (a server tick, the service's column
batches) calls `run_batch` once instead of World.move per move: the loop, the
target each move is given, the checks, the rollback and the writing of each
result into flat lists run in compiled code. Each item is exactly the
World.move / World.step call it stands for (engine.world.moves), in order,
so a mover named twice moves twice, the second time from where the first
left it; the answers are the same bit for bit.

The results come back as rows of two packed buffers (struct of arrays),
little-endian and written as each move ends, so that a caller turns a whole
batch into arrays with one call each (`np.frombuffer(rows.reals_le(), "<f8")`)
and no per-move object is read in interpreted code. The buffers are
librt.strings BytesWriters: compiled, a value goes into the buffer straight
from the result's unboxed double, with no Python float or list made for it.

- `reals`, REALS_PER_ROW float64s a row: origin (3), orientation w x y z (4),
  contact plane normal and d (4), collision normal (3), sliding normal (3);
  NaN where the result has no such value;
- `ints`, INTS_PER_ROW int64s a row: cell id, Status bits, the
  transient-state bits (engine.world.transient.TS), the transition state's
  index in TRANSITION_STATES, frames_stationary_fall, contact_plane_cell,
  how many collided-object ids the row adds to `collide_ids`, and the
  result's seq (the mover's move count after the move, Mover.seq), so that
  a reader has every row's seq as one column.

The layout is engine.world.rows's (ROW_REALS, ROW_INTS, Status), a leaf that
readers of the rows import without this module's machinery.

A row whose item did not run (no mover given, the mover refused the move)
holds NaN and zeros (seq 0 among them) with Status.RESOLVED clear.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable
from time import perf_counter
from typing import Final

from librt.strings import BytesWriter, write_f64_le, write_i64_le

from ..cells.landscape import Landscape
from ..geometry import Position, Quat, Vec3
from .mover import Mover
from .moves import move_checked, step_checked
from .rollback import MoveUndo
from .rows import INTS_PER_ROW, REALS_PER_ROW, TRANSITION_STATES, Status
from .transient import NAMED_BITS
from .types import MoveResult

__all__ = [
    "OFFSET",
    "TO",
    "MOTION",
    "REALS_PER_ROW",
    "INTS_PER_ROW",
    "TRANSITION_STATES",
    "Status",
    "BatchRows",
    "run_batch",
    "append_row",
    "append_missing",
    "MOVER_STATE_FIELDS",
    "MOVER_STATE_BYTES",
    "write_mover_state",
]

#: The move kinds of a batch: every item of one call is of one kind.
OFFSET: Final = 0  # target = the mover's position moved by a world-frame offset (World.move)
TO: Final = 1  # target = a given cell (0: the mover's own), origin and orientation (all zero: its own)
MOTION: Final = 2  # a physics step of dt seconds with the mover's own motion (World.step)

_STATE_INDEX: Final = {name: i for i, name in enumerate(TRANSITION_STATES)}

# The runs written for missing values, packed once
_NO_VECTOR: Final = struct.pack("<3d", *[math.nan] * 3)
_NO_PLANE: Final = struct.pack("<4d", *[math.nan] * 4)
_NO_REALS: Final = struct.pack(f"<{REALS_PER_ROW}d", *[math.nan] * REALS_PER_ROW)
_NO_INTS: Final = bytes(8 * INTS_PER_ROW)

#: A mover's whole state as `write_mover_state` writes it: little-endian, four int64s then 24 float64s
#: (vectors as x y z, the orientation as w x y z). `flags`: 1 missile, 2 colliding with the environment.
#: With it a mover is put back exactly as it stood (a service's journal, service/persistence/journal_records.py).
MOVER_STATE_FIELDS: Final = (
    ("cell_id", 1), ("transient", 1), ("contact_plane_cell_id", 1), ("flags", 1),
    ("origin", 3), ("orientation", 4), ("contact_plane_normal", 3), ("contact_plane_d", 1), ("sliding_normal", 3),
    ("velocity", 3), ("acceleration", 3), ("held_time", 1), ("held_motion", 3),
)
MOVER_STATE_BYTES: Final = 8 * 28
_NO_STATE: Final = bytes(MOVER_STATE_BYTES)


class BatchRows:
    """The rows of a batch so far, and what each item left behind."""

    def __init__(self) -> None:
        #: REALS_PER_ROW little-endian float64s a row (see the module's docstring)
        self.reals = BytesWriter()
        #: INTS_PER_ROW little-endian int64s a row
        self.ints = BytesWriter()
        #: rows written so far
        self.count = 0
        self.collide_ids: list[int] = []
        #: each item's MoveResult, None for items that did not run (in item order)
        self.results: list[MoveResult | None] = []
        #: (item index, the exception the engine raised) of items the engine refused
        self.errors: list[tuple[int, Exception]] = []
        #: per item that ran: seconds in the engine, and perf_counter() when it finished
        self.engine_seconds: list[float] = []
        self.finished_at: list[float] = []
        #: when `run_batch` stopped at an item (`stop_if`): what puts that item's mover back as it was
        #: before the item (MoveUndo.restore), should its move be refused after all
        self.undo: MoveUndo | None = None
        #: set by a caller that keeps each row's mover whole (write_mover_state after each row; zeros for a
        #: missing row); None: not kept
        self.states: BytesWriter | None = None

    def reals_le(self) -> bytes:
        """The real rows so far, `count` x REALS_PER_ROW float64s, little-endian."""
        return self.reals.getvalue()

    def ints_le(self) -> bytes:
        """The integer rows so far, `count` x INTS_PER_ROW int64s, little-endian."""
        return self.ints.getvalue()


def append_row(rows: BatchRows, r: MoveResult) -> None:
    """Add `r` as the next row."""
    pos = r.position
    frame = pos.frame
    o = frame.origin
    q = frame.orientation
    status = Status.RESOLVED
    if r.ok:
        status |= Status.OK
    if r.contact:
        status |= Status.CONTACT
    if r.on_walkable:
        status |= Status.ON_WALKABLE
    if r.water_contact:
        status |= Status.WATER_CONTACT
    reals = rows.reals
    _write_vector(reals, o)
    write_f64_le(reals, q.w)
    write_f64_le(reals, q.x)
    write_f64_le(reals, q.y)
    write_f64_le(reals, q.z)
    cp = r.contact_plane
    if cp is None:
        reals.write(_NO_PLANE)
    else:
        status |= Status.HAS_CONTACT_PLANE
        _write_vector(reals, cp.normal)
        write_f64_le(reals, cp.d)
    cn = r.collision_normal
    if cn is None:
        reals.write(_NO_VECTOR)
    else:
        status |= Status.HAS_COLLISION_NORMAL
        _write_vector(reals, cn)
    sn = r.sliding_normal
    if sn is None:
        reals.write(_NO_VECTOR)
    else:
        status |= Status.HAS_SLIDING_NORMAL
        _write_vector(reals, sn)
    cpc = r.contact_plane_cell
    plane_cell = 0
    if cpc is not None:
        status |= Status.HAS_CONTACT_PLANE_CELL
        plane_cell = cpc
    fsf = r.frames_stationary_fall
    stationary_fall = 0
    if fsf is not None:
        status |= Status.HAS_FRAMES_STATIONARY_FALL
        stationary_fall = fsf
    collide = r.collide_objects
    ints = rows.ints
    write_i64_le(ints, pos.cell_id)
    write_i64_le(ints, status)
    write_i64_le(ints, _transient_bits(r.transient_state))
    write_i64_le(ints, _STATE_INDEX[r.transition_state])
    write_i64_le(ints, stationary_fall)
    write_i64_le(ints, plane_cell)
    write_i64_le(ints, len(collide))
    write_i64_le(ints, r.seq)
    rows.count += 1
    if collide:
        rows.collide_ids.extend(collide)


def _write_vector(reals: BytesWriter, v: Vec3) -> None:
    write_f64_le(reals, v.x)
    write_f64_le(reals, v.y)
    write_f64_le(reals, v.z)


def append_missing(rows: BatchRows) -> None:
    """Add an empty row (an item that did not run)."""
    rows.reals.write(_NO_REALS)
    rows.ints.write(_NO_INTS)
    states = rows.states
    if states is not None:
        states.write(_NO_STATE)
    rows.count += 1


def write_mover_state(out: BytesWriter, mover: Mover) -> None:
    """Append `mover`'s whole state (MOVER_STATE_FIELDS: place, contact, velocity, time held over...) to
    `out`: what puts it back bit for bit after a restart."""
    pos = mover.position
    write_i64_le(out, pos.cell_id)
    write_i64_le(out, mover.transient)
    write_i64_le(out, mover.contact_plane_cell_id)
    flags = 0
    if mover.missile:
        flags |= 1
    if mover.colliding_with_environment:
        flags |= 2
    write_i64_le(out, flags)
    frame = pos.frame
    _write_vector(out, frame.origin)
    q = frame.orientation
    write_f64_le(out, q.w)
    write_f64_le(out, q.x)
    write_f64_le(out, q.y)
    write_f64_le(out, q.z)
    cp = mover.contact_plane
    _write_vector(out, cp.normal)
    write_f64_le(out, cp.d)
    _write_vector(out, mover.sliding_normal)
    _write_vector(out, mover.velocity)
    _write_vector(out, mover.acceleration)
    write_f64_le(out, mover.held_time)
    _write_vector(out, mover.held_motion)


_TRANSIENT_BIT: Final = {name: bit for name, bit in NAMED_BITS}


def _transient_bits(names: list[str]) -> int:
    bits = 0
    for name in names:
        bits |= _TRANSIENT_BIT[name]
    return bits


def _target(kind: int, mover: Mover, vectors: list[float], cells: list[int] | None,
            orientations: list[float] | None, i: int) -> Position:
    """Item `i`'s target position (kinds OFFSET and TO)."""
    pos = mover.position
    j = 3 * i
    origin = Vec3(vectors[j], vectors[j + 1], vectors[j + 2])
    if kind == OFFSET:
        return pos.moved(origin)
    cell = pos.cell_id
    if cells is not None and cells[i] != 0:
        cell = cells[i]
    orientation = pos.frame.orientation
    if orientations is not None:
        k = 4 * i
        w, x, y, z = orientations[k], orientations[k + 1], orientations[k + 2], orientations[k + 3]
        if w != 0.0 or x != 0.0 or y != 0.0 or z != 0.0:
            orientation = Quat(w, x, y, z)
    return Position.at(cell, origin, orientation)


def run_batch(
    landscape: Landscape,
    movers: list[Mover | None],
    kind: int,
    vectors: list[float],
    rows: BatchRows,
    *,
    start: int = 0,
    cells: list[int] | None = None,
    orientations: list[float] | None = None,
    velocities: list[float] | None = None,
    dts: list[float] | None = None,
    stop_if: Callable[[int], bool] | None = None,
) -> int:
    """Run items `start`, `start + 1`, ... of a batch of one `kind`, appending a row each to `rows`.

    `movers[i]` is item i's mover (None: the item does not run and gets an empty row); `vectors`
    holds 3 floats an item: the offset (OFFSET), the target origin (TO) or the motion (MOTION).
    TO may give `cells` (one an item, 0 for the mover's own) and `orientations` (w x y z an item,
    all zero for the mover's own); OFFSET and TO may give `velocities` (3 an item: the mover's
    velocity for that move only); MOTION needs `dts` (seconds, one an item).

    An item the engine refuses (engine.errors, or any other exception: the mover is then as before
    the item) gets an empty row and an entry in `rows.errors`. `stop_if(landblock id)` is asked of
    each result's landblock: when it says True the batch stops with that item's result in
    `rows.results` but no row written, and returns the item's index (the caller decides, then goes on
    from the next index; the mover's seq already counts the move, and `rows.undo` takes the move back,
    seq and last result included). Returns len(movers) when every item
    has run."""
    n = len(movers)
    results = rows.results
    for i in range(start, n):
        mover = movers[i]
        if mover is None:
            results.append(None)
            append_missing(rows)
            continue
        # a move that may stop the batch may be refused after it ended: kept so that it can be taken back
        undo = MoveUndo(mover) if stop_if is not None else None
        t0 = perf_counter()
        try:
            if kind == MOTION:
                assert dts is not None
                j = 3 * i
                result = step_checked(landscape, mover, Vec3(vectors[j], vectors[j + 1], vectors[j + 2]), dts[i])
            else:
                velocity: Vec3 | None = None
                if velocities is not None:
                    j = 3 * i
                    velocity = Vec3(velocities[j], velocities[j + 1], velocities[j + 2])
                result = move_checked(landscape, mover, _target(kind, mover, vectors, cells, orientations, i),
                                      velocity)
        except Exception as e:
            rows.errors.append((i, e))
            results.append(None)
            append_missing(rows)
            continue
        t1 = perf_counter()
        rows.engine_seconds.append(t1 - t0)
        rows.finished_at.append(t1)
        results.append(result)
        if stop_if is not None and stop_if((result.position.cell_id >> 16) & 0xFFFF):
            rows.undo = undo
            return i
        append_row(rows, result)
        states = rows.states
        if states is not None:
            write_mover_state(states, mover)
    return n
