"""The column form of a move batch, client side: numpy arrays in, numpy arrays out.

`Client.move_batch` packs its arguments into the request columns declared
in service/protocol/columns.py, sends one column request per landblock (the
landblock each mover was last seen in; every request goes out before any
reply is read, so that the instances serving them work at the same time),
follows `moved` hand-overs by
sending the items concerned again, and puts the reply columns back
together in the items' order as a `BatchResults`.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, cast

import numpy as np

from service.protocol.columns import (
    REPLY_COLUMNS,
    REQUEST_BY_NAME,
    REQUEST_COLUMNS,
    TRANSIENT_FLAGS,
    TRANSITION_STATES,
    Column,
    Flag,
    pack_columns,
    unpack_column,
)
from service.protocol.wire import ErrorKind

from clients.errors import AcphysError, ServiceError
from clients.request_channel import PendingRequest, RequestChannel

__all__ = ["BatchResults", "move_batch"]

_REDIRECTS = (ErrorKind.MOVED, ErrorKind.WRONG_LANDBLOCK)
_MAX_REDIRECTS = 4
Array = np.ndarray[Any, Any]


def _flag_column(bit: int, doc: str) -> Any:
    """A read-only property: which rows have `bit` of their `flags` set (a bool array)."""
    def read(self: BatchResults) -> Array:
        return (self.flags & bit) != 0
    read.__doc__ = doc
    return property(read)


@dataclass(slots=True)
class BatchResults:
    """The results of `Client.move_batch`, one row per move in the order given (docs/protocol.md, "Column
    reply" for every column's meaning and missing value). A failed move's row holds the missing values
    and its error is in `errors`, by index.

    The columns, numpy arrays of n rows: `seq` (uint64); `cell` (uint32 cell ids, 0xXXYYIIII);
    `origin` (n, 3) landblock-local metres; `orientation` (n, 4) w x y z; `flags` (uint32 bits:
    `resolved`, `ok`, `contact`, ... below); `transition_state` (uint8 codes, `transition_name`
    names them; 255 for a failed move); `frames_stationary_fall` (uint8, 255: none); `contact_plane`
    (n, 4) normal x y z then d, in metres, in the frame of `contact_plane_cell`'s landblock (NaN when
    none); `contact_plane_cell` (uint32, 0 when none); `collision_normal` and `sliding_normal` (n, 3)
    (NaN when none); `collide_count` (uint32) with `collide_ids` (uint64, every move's collided mover ids
    one move after the other; `collide_objects(i)` picks move i's). The missing values: NaN for
    floats, 0 for ids and counts, 255 for codes.
    """

    seq: Array  # (n,) uint64
    cell: Array  # (n,) uint32
    origin: Array  # (n, 3) float64
    orientation: Array  # (n, 4) float64, w x y z
    flags: Array  # (n,) uint32, service.protocol.columns.Flag bits
    transition_state: Array  # (n,) uint8, index into TRANSITION_STATES (255: failed)
    frames_stationary_fall: Array  # (n,) uint8 (255: none)
    contact_plane: Array  # (n, 4) float64: nx ny nz d
    contact_plane_cell: Array  # (n,) uint32
    collision_normal: Array  # (n, 3) float64
    sliding_normal: Array  # (n, 3) float64
    collide_count: Array  # (n,) uint32
    collide_ids: Array  # (sum of collide_count,) uint64, item after item
    errors: dict[int, AcphysError] = field(default_factory=dict)

    @classmethod
    def empty(cls, n: int) -> BatchResults:
        """Results of `n` moves that all hold the missing values, with no errors (what a batch fills in)."""
        arrays = {col.name: col.missing_rows(n) for col in REPLY_COLUMNS}
        made: BatchResults = cast(Any, cls)(**arrays, collide_ids=np.zeros(0, dtype=np.uint64))
        return made

    def __len__(self) -> int:
        """The number of moves (rows)."""
        return len(self.seq)

    resolved = _flag_column(Flag.RESOLVED, "Which moves have a result (bool array; False: see `errors`).")
    ok = _flag_column(Flag.OK, "Which moves found a position (bool array; False also for a failed move).")
    contact = _flag_column(Flag.CONTACT, "Which movers touch a surface after their move (bool array).")
    on_walkable = _flag_column(Flag.ON_WALKABLE, "Which movers stand on walkable ground after their move (bool array).")
    water_contact = _flag_column(Flag.WATER_CONTACT, "Which movers are in water after their move (bool array).")

    @property
    def landblock(self) -> Array:
        """Each row's landblock, 0xXXYY, from its `cell` (0 for a failed move)."""
        return (self.cell >> 16) & 0xFFFF

    def transition_name(self, i: int) -> str | None:
        """Move `i`'s transition state by name ("OK", "Collided", "Adjusted", "Slid", "Invalid",
        "NoTransition"); None for a failed move."""
        code = int(self.transition_state[i])
        return TRANSITION_STATES[code] if code < len(TRANSITION_STATES) else None

    def transient_state(self, i: int) -> list[str]:
        """Move `i`'s transient state flags by name (of "Contact", "OnWalkable", "Sliding", "WaterContact",
        "StationaryFall", "StationaryStop", "StationaryStuck"); empty for a failed move."""
        bits = int(self.flags[i]) >> Flag.TRANSIENT_SHIFT
        return [name for k, name in enumerate(TRANSIENT_FLAGS) if bits & (1 << k)]

    def collide_objects(self, i: int) -> list[int]:
        """The ids of the other movers move `i` touched, in order (its share of `collide_ids`)."""
        start = int(self.collide_count[:i].sum())
        return [int(x) for x in self.collide_ids[start:start + int(self.collide_count[i])]]


def _rows(name: str, value: Any, n: int) -> Array:
    """A request argument as the column's array: (n,) or (n, width); a scalar `dt` is repeated."""
    return column_rows(REQUEST_BY_NAME[name], value, n)


def column_rows(col: Column, value: Any, n: int) -> Array:
    """`value` as column `col`'s array: (n,) or (n, width); a scalar is repeated for a width-1 column.
    ValueError for another shape. Shared with the queries' column form (clients/query_columns.py)."""
    a = np.asarray(value, dtype=col.np_dtype.newbyteorder("="))
    if col.width == 1 and a.ndim == 0:
        a = np.full(n, a)
    want = (n,) if col.width == 1 else (n, col.width)
    if a.shape != want:
        raise ValueError(f"{col.name}: expected shape {want}, got {a.shape}")
    return a


def request_arrays(ids: Any, offsets: Any = None, targets: Any = None, motions: Any = None, dt: Any = None, *,
                   cells: Any = None, orientations: Any = None, velocities: Any = None) -> tuple[str, dict[str, Array]]:
    """The kind and the request columns of a batch (ValueError for a wrong combination or shape)."""
    id_arr = np.asarray(ids, dtype=np.uint64).reshape(-1)
    n = len(id_arr)
    given = [k for k, v in (("offset", offsets), ("to", targets), ("motion", motions)) if v is not None]
    if len(given) != 1:
        raise ValueError(f"give exactly one of offsets, targets, motions (got {', '.join(given) or 'none'})")
    kind = given[0]
    named = {"offset": offsets, "to_origin": targets, "to_cell": cells, "to_orientation": orientations,
             "motion": motions, "dt": dt, "velocity": velocities}
    arrays: dict[str, Array] = {"id": id_arr}
    for name, value in named.items():
        if value is None:
            continue
        if not REQUEST_BY_NAME[name].allowed(kind):
            raise ValueError(f"{name} does not go with kind {kind}")
        arrays[name] = _rows(name, value, n)
    for col in REQUEST_COLUMNS:
        if kind in col.required and col.name not in arrays:
            raise ValueError(f"{col.name} is required with {kind}")
    return kind, arrays


def _scatter(out: BatchResults, idx: Array, cols: dict[str, Array]) -> None:
    """One landblock's reply rows into their places in `out`."""
    for col in REPLY_COLUMNS:
        getattr(out, col.name)[idx] = cols[col.name]


def _keep_collisions(idx: Array, cols: dict[str, Array], collide: list[tuple[int, Array]]) -> None:
    """A reply's collided ids, kept by the batch index of their item (the batch's are put in order at the end)."""
    if not len(cols["collide_ids"]):  # the usual reply: nothing collided with a mover (counts all 0, checked)
        return
    counts = cols["collide_count"].astype(np.int64)
    ids = cols["collide_ids"]
    ends = np.cumsum(counts).tolist()
    for j in np.flatnonzero(counts).tolist():
        collide.append((int(idx[j]), ids[ends[j] - int(counts[j]):ends[j]]))


def _learn_landblocks(client: RequestChannel, lb: int, ids: Array, idx: Array, cols: dict[str, Array]) -> None:
    """Remember the landblock each resolved item of a reply to `lb`'s request ended in. The usual reply
    (every item resolved, none left `lb`) changes nothing the client knew, and is checked as such with
    three array operations instead of a dictionary update per item."""
    landblocks = (cols["cell"] >> 16) & 0xFFFF
    resolved = (cols["flags"] & Flag.RESOLVED) != 0
    if resolved.all() and (landblocks == lb).all():
        return
    client.known_landblocks.update(zip(ids[idx[resolved]].tolist(), landblocks[resolved].tolist()))


def _whole(cols: dict[str, Array]) -> BatchResults:
    """The results of a batch answered by one reply, every item in it in order: its columns as they
    came, copied (the reply's buffers are read-only)."""
    made: BatchResults = cast(Any, BatchResults)(**{col.name: cols[col.name].copy() for col in REPLY_COLUMNS},
                                                 collide_ids=cols["collide_ids"].copy())
    return made


def _groups(client: RequestChannel, pending: Sequence[int], id_list: list[int], out_errors: dict[int, AcphysError]
            ) -> dict[int, list[int]]:
    """The items of `pending` by the landblock each mover was last seen in (asking where unknown); an
    item whose mover cannot be found gets its error in `out_errors`."""
    where = client.known_landblocks
    # the first attempt (range(n)) sends every item: their landblocks looked up in one C loop
    seen = list(map(where.get, id_list)) if isinstance(pending, range) else [where.get(id_list[i]) for i in pending]
    first = seen[0] if seen else None
    if first is not None and seen.count(first) == len(seen):  # the usual batch: one landblock, all known
        return {first: list(pending)}
    groups: dict[int, list[int]] = {}
    for i, lb in zip(pending, seen):
        if lb is None:
            try:
                lb = client.landblock_of(id_list[i])
            except AcphysError as e:
                out_errors[i] = e
                continue
        groups.setdefault(lb, []).append(i)
    return groups


def _read_reply(reply: dict[str, Any], m: int) -> tuple[dict[str, Array], list[Any]]:
    """The reply's columns (m rows) and error entries; ServiceError when they do not fit."""
    cols_raw, errors = reply.get("columns"), reply.get("errors")
    if reply.get("n") != m or not isinstance(cols_raw, dict) or not isinstance(errors, list):
        raise ServiceError(ErrorKind.MALFORMED, "column reply does not match the request")
    cols: dict[str, Array] = {}
    try:
        for col in REPLY_COLUMNS:
            cols[col.name] = unpack_column(col, cols_raw[col.name], m)
        total = int(cols["collide_count"].sum())
        raw_ids = cols_raw["collide_ids"]
        if not isinstance(raw_ids, bytes) or len(raw_ids) != 8 * total:
            raise ValueError("collide_ids")
        cols["collide_ids"] = np.frombuffer(raw_ids, dtype="<u8").astype(np.uint64)
    except (KeyError, ValueError, TypeError) as e:
        raise ServiceError(ErrorKind.MALFORMED, f"unreadable column reply: {e}") from None
    return cols, errors


def _reindexed(err: ServiceError, sent: int, given: int) -> ServiceError:
    """The error with its path's item index as the caller gave it (`sent`: its index in the request that
    went to one landblock, a subset of the batch)."""
    if sent == given or not err.path:
        return err
    m = re.match(r"columns\.\w+\[(\d+)\]", err.path)
    if m is None or int(m.group(1)) != sent:
        return err
    path = f"{err.path[:m.start(1)]}{given}{err.path[m.end(1):]}"
    return type(err)(err.kind, err.message.replace(err.path, path), path, {**err.details, "path": path})


def move_batch(client: RequestChannel, ids: Any, offsets: Any = None, targets: Any = None, motions: Any = None,
               dt: Any = None, *, cells: Any = None, orientations: Any = None, velocities: Any = None,
               publish: str | None = None, timeout: float | None = None) -> BatchResults:
    """See `Client.move_batch`."""
    kind, arrays = request_arrays(ids, offsets, targets, motions, dt, cells=cells, orientations=orientations,
                                  velocities=velocities)
    id_list: list[int] = arrays["id"].tolist()
    n = len(id_list)
    out: BatchResults | None = None  # made when the replies do not simply give it (see `_whole`)
    errors: dict[int, AcphysError] = {}
    collide: list[tuple[int, Array]] = []
    pending: Sequence[int] = range(n)
    for attempt in range(_MAX_REDIRECTS + 1):
        retry: list[int] = []
        sent: list[tuple[int, list[int], bool, Array, PendingRequest]] = []
        for lb, members in _groups(client, pending, id_list, errors).items():
            whole = len(members) == n  # every item in this one request, in order: sent and taken as they are
            idx = np.arange(n, dtype=np.intp) if whole else np.array(members, dtype=np.intp)
            body: dict[str, Any] = {"kind": kind, "columns": pack_columns(
                REQUEST_COLUMNS, arrays if whole else {k: a[idx] for k, a in arrays.items()})}
            if publish is not None:
                body["publish"] = publish
            # every landblock's request on its way before any reply is read: their instances work at once
            sent.append((lb, members, whole, idx, client.send_request(client.keys.move(lb), body, timeout)))
        for lb, members, whole, idx, request in sent:
            try:
                cols, reply_errors = _read_reply(client.receive_reply(request), len(members))
            except AcphysError as e:
                for i in members:
                    errors[i] = e
                continue
            if whole:
                out = _whole(cols)
            else:
                if out is None:
                    out = BatchResults.empty(n)
                _scatter(out, idx, cols)
            _keep_collisions(idx, cols, collide)
            _learn_landblocks(client, lb, arrays["id"], idx, cols)
            for entry in reply_errors:
                j = entry.get("index") if isinstance(entry, dict) else None
                if type(j) is not int or not 0 <= j < len(members):
                    continue
                i = members[j]
                err_map = entry.get("error")
                target = err_map.get("landblock") if isinstance(err_map, dict) else None
                if isinstance(err_map, dict) and err_map.get("kind") in _REDIRECTS and isinstance(target, int) \
                        and attempt < _MAX_REDIRECTS:
                    client.known_landblocks[id_list[i]] = target
                    retry.append(i)
                    continue
                errors[i] = _reindexed(ServiceError.from_wire(err_map), j, i)
        if not retry:
            break
        pending = sorted(retry)  # their rows, failed in the reply above, are written over
    if out is None:
        out = BatchResults.empty(n)
    out.errors = errors
    if collide:
        collide.sort(key=lambda t: t[0])
        out.collide_ids = np.concatenate([a for _, a in collide])
    return out
