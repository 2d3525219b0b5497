"""Many moves in one call, results as flat rows: the engine's batch entry point.

A caller holding many moves of one kind (a server tick, the service's column
batches) calls `run_batch` once instead of World.move per move: the loop, the
target each move is given, the checks, the rollback and the writing of each
result into flat lists run in compiled code. Each item is exactly the
World.move / World.step call it stands for (engine.world.moves), in order,
so a mover named twice moves twice, the second time from where the first
left it; the answers are the same bit for bit.

The results come back a column at a time (struct of arrays): one
little-endian buffer per column of engine.world.rows.RESULT_COLUMNS, each in
its column's own type and written as each move ends, so that a caller hands
them on as they are (the service's column replies are these buffers) or
reads each with one `np.frombuffer`, and no per-move object is read in
interpreted code. The buffers are librt.strings BytesWriters: compiled, a
value goes into its buffer straight from the result's unboxed double, with
no Python float or list made for it.

An item that did not run (no mover given, the mover refused the move) holds
NaN in its reals, 255 (rows.NO_CODE) in its codes and zeros elsewhere, seq 0
among them, with Status.RESOLVED clear.
"""

from __future__ import annotations

import math
import struct
from collections.abc import Callable
from time import perf_counter
from typing import Final, TypeAlias

from librt.strings import BytesWriter, read_f64_le, write_f64_le, write_i32_le, write_i64_le

from ..cells.landscape import Landscape
from ..geometry import Position, Quat, Vec3
from .mover import Mover
from .moves import move_checked, step_checked
from .rollback import MoveUndo
from .rows import NO_CODE, RESULT_COLUMNS, TRANSIENT_SHIFT, TRANSITION_STATES, Status
from .transient import NAMED_BITS
from .types import MoveResult

__all__ = [
    "OFFSET",
    "TO",
    "Reals",
    "MOTION",
    "RESULT_COLUMNS",
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

#: An item's real values in a batch: Python floats in a list, or the same values as little-endian float64
#: bytes (a request column's bytes as they came, read in place by the compiled loop: no Python float is made
#: for them, and each value is the double it encodes, bit for bit)
Reals: TypeAlias = list[float] | bytes

# The values written for missing ones, packed once
_NO_VECTOR: Final = struct.pack("<3d", *[math.nan] * 3)
_NO_PLANE: Final = struct.pack("<4d", *[math.nan] * 4)
_NO_QUAT: Final = _NO_PLANE
_NO_U64: Final = bytes(8)
_NO_U32: Final = bytes(4)
_NO_CODE: Final = bytes([NO_CODE])
#: each u8 value as one byte (a code is written without making a bytes object per move)
_BYTE: Final = tuple(bytes((i,)) for i in range(256))

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
    """The results of a batch so far, a column each (engine.world.rows.RESULT_COLUMNS), and what each item
    left behind."""

    def __init__(self) -> None:
        # one writer per result column, in RESULT_COLUMNS' order and types
        self.seq = BytesWriter()
        self.cell = BytesWriter()
        self.origin = BytesWriter()
        self.orientation = BytesWriter()
        self.flags = BytesWriter()
        self.transition_state = BytesWriter()
        self.frames_stationary_fall = BytesWriter()
        self.contact_plane = BytesWriter()
        self.contact_plane_cell = BytesWriter()
        self.collision_normal = BytesWriter()
        self.sliding_normal = BytesWriter()
        self.collide_count = BytesWriter()
        #: items written so far (each column holds this many)
        self.count = 0
        self.collide_ids: list[int] = []
        #: each item's MoveResult, None for items that did not run (in item order)
        self.results: list[MoveResult | None] = []
        #: (item index, the exception the engine raised) of items the engine refused
        self.errors: list[tuple[int, Exception]] = []
        #: per item the engine resolved, as little-endian float64s: its seconds in the engine, and
        #: perf_counter() when it finished (doubles, not Python floats: the service's stats keep them)
        self.engine_seconds = BytesWriter()
        self.finished_at = BytesWriter()
        #: items the engine resolved (each has its two times above)
        self.resolved = 0
        #: when `run_batch` stopped at an item (`stop_if`): what puts that item's mover back as it was
        #: before the item (MoveUndo.restore), should its move be refused after all
        self.undo: MoveUndo | None = None
        #: set by a caller that keeps each item's mover whole (write_mover_state after each item; zeros for
        #: one that did not run); None: not kept
        self.states: BytesWriter | None = None

    def columns(self) -> dict[str, bytes]:
        """Every result column so far, by name in RESULT_COLUMNS' order: `count` values each, little-endian."""
        return {
            "seq": self.seq.getvalue(),
            "cell": self.cell.getvalue(),
            "origin": self.origin.getvalue(),
            "orientation": self.orientation.getvalue(),
            "flags": self.flags.getvalue(),
            "transition_state": self.transition_state.getvalue(),
            "frames_stationary_fall": self.frames_stationary_fall.getvalue(),
            "contact_plane": self.contact_plane.getvalue(),
            "contact_plane_cell": self.contact_plane_cell.getvalue(),
            "collision_normal": self.collision_normal.getvalue(),
            "sliding_normal": self.sliding_normal.getvalue(),
            "collide_count": self.collide_count.getvalue(),
        }


assert tuple(BatchRows().columns()) == tuple(name for name, _type, _width in RESULT_COLUMNS)


def append_row(rows: BatchRows, r: MoveResult) -> None:
    """Add `r` as the next item's values."""
    pos = r.position
    frame = pos.frame
    status = Status.RESOLVED
    if r.ok:
        status |= Status.OK
    if r.contact:
        status |= Status.CONTACT
    if r.on_walkable:
        status |= Status.ON_WALKABLE
    if r.water_contact:
        status |= Status.WATER_CONTACT
    write_i64_le(rows.seq, r.seq)  # a count: far below 2^63, so its u64 bytes
    _write_u32(rows.cell, pos.cell_id)
    _write_vector(rows.origin, frame.origin)
    q = frame.orientation
    out = rows.orientation
    write_f64_le(out, q.w)
    write_f64_le(out, q.x)
    write_f64_le(out, q.y)
    write_f64_le(out, q.z)
    cp = r.contact_plane
    if cp is None:
        rows.contact_plane.write(_NO_PLANE)
    else:
        status |= Status.HAS_CONTACT_PLANE
        _write_vector(rows.contact_plane, cp.normal)
        write_f64_le(rows.contact_plane, cp.d)
    cn = r.collision_normal
    if cn is None:
        rows.collision_normal.write(_NO_VECTOR)
    else:
        status |= Status.HAS_COLLISION_NORMAL
        _write_vector(rows.collision_normal, cn)
    sn = r.sliding_normal
    if sn is None:
        rows.sliding_normal.write(_NO_VECTOR)
    else:
        status |= Status.HAS_SLIDING_NORMAL
        _write_vector(rows.sliding_normal, sn)
    cpc = r.contact_plane_cell
    if cpc is None:
        rows.contact_plane_cell.write(_NO_U32)
    else:
        status |= Status.HAS_CONTACT_PLANE_CELL
        _write_u32(rows.contact_plane_cell, cpc)
    fsf = r.frames_stationary_fall
    if fsf is None:
        rows.frames_stationary_fall.write(_NO_CODE)
    else:
        status |= Status.HAS_FRAMES_STATIONARY_FALL
        rows.frames_stationary_fall.write(_BYTE[fsf & 0xFF])
    _write_u32(rows.flags, status | (_transient_bits(r.transient_state) << TRANSIENT_SHIFT))
    rows.transition_state.write(_BYTE[_STATE_INDEX[r.transition_state]])
    collide = r.collide_objects
    _write_u32(rows.collide_count, len(collide))
    rows.count += 1
    if collide:
        rows.collide_ids.extend(collide)


def _write_u32(out: BytesWriter, value: int) -> None:
    """`value` (0 <= value < 2^32) as a little-endian u32: the same four bytes as the i32 it wraps to
    (librt's typed writers that mypyc knows are the signed ones)."""
    write_i32_le(out, value - 0x1_0000_0000 if value >= 0x8000_0000 else value)


def _write_vector(reals: BytesWriter, v: Vec3) -> None:
    write_f64_le(reals, v.x)
    write_f64_le(reals, v.y)
    write_f64_le(reals, v.z)


def append_missing(rows: BatchRows) -> None:
    """Add an item that did not run: NaN reals, NO_CODE codes, zeros elsewhere (engine.world.rows)."""
    rows.seq.write(_NO_U64)
    rows.cell.write(_NO_U32)
    rows.origin.write(_NO_VECTOR)
    rows.orientation.write(_NO_QUAT)
    rows.flags.write(_NO_U32)
    rows.transition_state.write(_NO_CODE)
    rows.frames_stationary_fall.write(_NO_CODE)
    rows.contact_plane.write(_NO_PLANE)
    rows.contact_plane_cell.write(_NO_U32)
    rows.collision_normal.write(_NO_VECTOR)
    rows.sliding_normal.write(_NO_VECTOR)
    rows.collide_count.write(_NO_U32)
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


def _real(values: Reals, k: int) -> float:
    """Value `k` of `values`: a list's k-th float, or the k-th little-endian float64 of the bytes."""
    if isinstance(values, bytes):
        return read_f64_le(values, 8 * k)
    return values[k]


def _vector(values: Reals, i: int) -> Vec3:
    """Item `i`'s vector: values 3i, 3i + 1 and 3i + 2 (the kind of `values` told once for the three)."""
    if isinstance(values, bytes):
        at = 24 * i
        return Vec3(read_f64_le(values, at), read_f64_le(values, at + 8), read_f64_le(values, at + 16))
    j = 3 * i
    return Vec3(values[j], values[j + 1], values[j + 2])


def _target(kind: int, mover: Mover, vectors: Reals, cells: list[int] | None,
            orientations: Reals | None, i: int) -> Position:
    """Item `i`'s target position (kinds OFFSET and TO)."""
    pos = mover.position
    origin = _vector(vectors, i)
    if kind == OFFSET:
        return pos.moved(origin)
    cell = pos.cell_id
    if cells is not None and cells[i] != 0:
        cell = cells[i]
    orientation = pos.frame.orientation
    if orientations is not None:
        k = 4 * i
        w, x, y = _real(orientations, k), _real(orientations, k + 1), _real(orientations, k + 2)
        z = _real(orientations, k + 3)
        if w != 0.0 or x != 0.0 or y != 0.0 or z != 0.0:
            orientation = Quat(w, x, y, z)
    return Position.at(cell, origin, orientation)


def run_batch(
    landscape: Landscape,
    movers: list[Mover | None],
    kind: int,
    vectors: Reals,
    rows: BatchRows,
    *,
    start: int = 0,
    cells: list[int] | None = None,
    orientations: Reals | None = None,
    velocities: Reals | None = None,
    dts: Reals | None = None,
    stop_if: Callable[[int], bool] | None = None,
) -> int:
    """Run items `start`, `start + 1`, ... of a batch of one `kind`, appending a row each to `rows`.

    `movers[i]` is item i's mover (None: the item does not run and gets an empty row); `vectors`
    holds 3 floats an item: the offset (OFFSET), the target origin (TO) or the motion (MOTION).
    TO may give `cells` (one an item, 0 for the mover's own) and `orientations` (w x y z an item,
    all zero for the mover's own); OFFSET and TO may give `velocities` (3 an item: the mover's
    velocity for that move only); MOTION needs `dts` (seconds, one an item). Each real argument is a
    list of floats or the same values as little-endian float64 bytes (`Reals`: a column's bytes as they
    are, with no Python float made per value).

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
                result = step_checked(landscape, mover, _vector(vectors, i), _real(dts, i))
            else:
                velocity: Vec3 | None = None
                if velocities is not None:
                    velocity = _vector(velocities, i)
                result = move_checked(landscape, mover, _target(kind, mover, vectors, cells, orientations, i),
                                      velocity)
        except Exception as e:
            rows.errors.append((i, e))
            results.append(None)
            append_missing(rows)
            continue
        t1 = perf_counter()
        write_f64_le(rows.engine_seconds, t1 - t0)
        write_f64_le(rows.finished_at, t1)
        rows.resolved += 1
        results.append(result)
        if stop_if is not None and stop_if((result.position.cell_id >> 16) & 0xFFFF):
            rows.undo = undo
            return i
        append_row(rows, result)
        states = rows.states
        if states is not None:
            write_mover_state(states, mover)
    return n
