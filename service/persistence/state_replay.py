"""What `--state FILE` holds at a start: the state file, then its logs replayed in order.

`load_saved` reads FILE (service/persistence/state_file.py) and every log of a
generation it does not hold (service/persistence/journal.py), applies their records
(service/persistence/journal_records.py) mover by mover, and returns the movers as
they stood after the last whole record. A log's torn tail is dropped with
a log line. A record that is damaged, or that does not fit what comes
before it (a move of a mover not held, a register of one already held),
stops the start with StateFileError naming the log; with `discard_bad`
that log and the later ones are set aside (renamed, never deleted) and
the movers come back as of the last whole record before the damage.

After a crash (a log was replayed) every mover's seq continues above any
seq the last run may have answered: + the log's seq budget + 1 (0 under
`always`, which answers nothing it has not synced), plus, when a damaged
log was set aside, one for every move its bytes could have held.
"""

from __future__ import annotations

import logging
import struct
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import msgpack
import numpy as np

from engine.world.batch import MOVER_STATE_BYTES
from engine import MoverSpec

from service.protocol.codec import decode_mover_spec, encode_mover_spec, encode_vec
from service.protocol.errors import ProtocolError
from service.persistence.journal import (
    DEFAULT_BUDGET,
    FRAME_HEAD,
    FrameRun,
    JournalCorrupt,
    JournalScan,
    journal_files,
)
from service.persistence.frame_runs import check_run
from service.persistence.journal_records import (
    HANDING_OVER,
    HANDOVER_FAILED,
    HANDOVER_IN,
    HANDOVER_OUT,
    KIND_NAMES,
    MOVES,
    RECORD_HEAD,
    REGISTER,
    REMOVE,
    UPDATE,
    decode_state,
)
from service.protocol.messages import HANDOVER, HandoverRequest
from service.persistence.state_file import SavedMover, StateFileError, read_snapshot, set_aside

__all__ = ["Loaded", "load_saved", "replay"]

log = logging.getLogger("acphys.service")

_encode_handover = HANDOVER.encode_fn()
_HINT = "use --state-discard-bad to start without it"
#: the fewest bytes one logged move takes (frame header, record head, id, seq, state): bounds the moves a
#: damaged log could have held
_MOVE_BYTES = 16 + MOVER_STATE_BYTES
_ONE_MOVE = RECORD_HEAD.size + _MOVE_BYTES
_ID = struct.Struct("<Q")
#: a moves record of this many rows or more finds its movers' last rows with numpy, not row by row
_BULK_ROWS = 16


@dataclass(slots=True)
class Loaded:
    """The movers of FILE and its logs, and what a start does next."""

    movers: list[SavedMover] | None  # None: no file and no log (a first start)
    #: the generation a new log opens at (after every log present)
    generation: int
    #: the logs read (to delete once a new state file holds them), and those the state file already held
    replayed: list[Path] = field(default_factory=list)
    stale: list[Path] = field(default_factory=list)
    #: what every mover's seq was raised by (0: no log, or every log written under `always`)
    jump: int = 0
    records: int = 0
    #: movers whose last record is a hand-over sent with no outcome logged: mover -> the landblock it was
    #: sent to (whose owner the start asks whether it took it)
    in_doubt: dict[int, int] = field(default_factory=dict)


class _Replay:
    """Movers as the records leave them: the state file's (untouched), or a record's row. A later row of a
    mover supersedes an earlier one whole (it holds the mover's seq and whole state), so a run of moves keeps
    only each mover's last row: it is found for many records at once (numpy) and its bytes copied then."""

    def __init__(self, saved: list[SavedMover]) -> None:
        self.base: dict[int, SavedMover] = {m.handover.id: m for m in saved}
        self.alive: set[int] = set(self.base)
        #: the latest row of a mover a record changed: (bytes holding it, where its seq is, where its state is)
        self.rows: dict[int, tuple[bytes, int, int]] = {}
        self.specs: dict[int, MoverSpec] = {}
        self.in_doubt: dict[int, int] = {}
        #: the records applied (whole)
        self.records = 0

    def apply(self, payload: bytes) -> None:
        kind, n = RECORD_HEAD.unpack_from(payload, 0)
        at = RECORD_HEAD.size
        if kind == MOVES and n == 1 and len(payload) == _ONE_MOVE:  # a single move's record: the common case
            (mover_id,) = _ID.unpack_from(payload, at)
            if mover_id not in self.alive:
                raise ValueError(f"a moves record changes mover {mover_id:X}, which is not held")
            self.rows[mover_id] = (payload, at + 8, at + 16)
            if self.in_doubt:
                self.in_doubt.pop(mover_id, None)
            self.records += 1
            return
        if kind == MOVES and n >= _BULK_ROWS and len(payload) >= at + n * _MOVE_BYTES:
            ids = np.frombuffer(payload, np.dtype("<u8"), n, at).copy()
            self._moves(ids, n, lambda r: (payload, at + 8 * n + 8 * r, at + 16 * n + MOVER_STATE_BYTES * r))
            return
        self._apply(kind, n, payload)
        self.records += 1

    def apply_run(self, run: FrameRun) -> None:
        """The records of `run` in order: its moves in bulk when all are MOVES records of one size, else one
        by one."""
        heads = run.column(0, RECORD_HEAD.size)
        kinds = heads[:, 0]
        counts = heads[:, 1:].copy().view(np.dtype("<u4")).reshape(-1)
        n = int(counts[0])
        at = RECORD_HEAD.size
        if not ((kinds == MOVES).all() and (counts == n).all() and n and run.length >= at + n * _MOVE_BYTES):
            for i in range(run.count):
                self.apply(run.payload(i))
            return
        ids = run.column(at, 8 * n).view(np.dtype("<u8")).reshape(-1)
        seqs, states = at + 8 * n, at + 16 * n

        def row(r: int) -> tuple[bytes, int, int]:
            """Row `r` of the run (frame r // n, row r % n of it): its seq and state copied out of the file."""
            i, j = divmod(r, n)
            base = run.offset + i * run.stride + FRAME_HEAD
            seq = run.data[base + seqs + 8 * j:base + seqs + 8 * j + 8]
            state = run.data[base + states + MOVER_STATE_BYTES * j:base + states + MOVER_STATE_BYTES * (j + 1)]
            return seq + state, 0, 8

        self._moves(ids, n, row)

    def _moves(self, ids: np.ndarray[Any, np.dtype[np.uint64]], per: int,
               row: Callable[[int], tuple[bytes, int, int]]) -> None:
        """Records of `per` moves each, their ids `ids` in order: each mover's last row kept (`row` gives it by
        its index in `ids`). Every mover must be held (no record of another kind comes between, so what is
        held does not change): else the records before the first that is not are applied, and ValueError."""
        last = len(ids) - 1
        unique, first_reversed = np.unique(ids[::-1], return_index=True)
        movers = unique.tolist()
        if not self.alive.issuperset(movers):
            strangers = np.array(sorted(set(movers) - self.alive), dtype=np.uint64)
            bad = int(np.flatnonzero(np.isin(ids, strangers))[0]) // per
            if bad:
                self._moves(ids[:bad * per], per, row)
            record = set(ids[bad * per:(bad + 1) * per].tolist()) - self.alive
            raise ValueError(f"a moves record changes mover {min(record):X}, which is not held")
        rows = self.rows
        for mover_id, r in zip(movers, (last - first_reversed).tolist()):
            rows[mover_id] = row(r)
        if self.in_doubt:
            for mover_id in movers:  # moved here after a hand-over was sent: it stayed here
                self.in_doubt.pop(mover_id, None)
        self.records += len(ids) // per

    def _apply(self, kind: int, n: int, payload: bytes) -> None:
        """One record of any kind, row by row."""
        at = RECORD_HEAD.size
        ids = list(struct.unpack_from(f"<{n}Q", payload, at))
        if kind == MOVES or kind == REGISTER or kind == UPDATE or kind == HANDOVER_IN:
            need = at + n * _MOVE_BYTES
            if len(payload) < need:
                raise ValueError(f"a {KIND_NAMES[kind]} record of {n} mover(s) is {len(payload)} bytes")
            if kind == REGISTER or kind == HANDOVER_IN:
                held = self.alive.intersection(ids)
                if held:
                    raise ValueError(f"a {KIND_NAMES[kind]} record adds mover {min(held):X}, which is held already")
            elif not self.alive.issuperset(ids):
                raise ValueError(f"a {KIND_NAMES[kind]} record changes mover "
                                 f"{min(set(ids) - self.alive):X}, which is not held")
            specs: list[MoverSpec] = []
            if kind != MOVES:  # (decoded before anything changes: a record is applied whole or not at all)
                raw = msgpack.unpackb(payload[need:], raw=False, strict_map_key=False)
                if not isinstance(raw, list) or len(raw) != n:
                    raise ValueError(f"a {KIND_NAMES[kind]} record's movers are not {n} maps")
                for mover_id, spec in zip(ids, raw):
                    try:
                        specs.append(decode_mover_spec(spec, "mover"))
                    except ProtocolError as e:
                        raise ValueError(f"mover {mover_id:X}: {e.message}") from None
            if kind == REGISTER or kind == HANDOVER_IN:
                self.alive.update(ids)
            self.rows.update((mover_id, (payload, at + 8 * n + 8 * i, at + 16 * n + MOVER_STATE_BYTES * i))
                             for i, mover_id in enumerate(ids))
            self.specs.update(zip(ids, specs))
            if self.in_doubt:
                for mover_id in ids:  # changed here after a hand-over was sent: it stayed here
                    self.in_doubt.pop(mover_id, None)
        elif kind == HANDING_OVER or kind == HANDOVER_FAILED:
            if not self.alive.issuperset(ids):
                raise ValueError(f"a {KIND_NAMES[kind]} record names mover {min(set(ids) - self.alive):X}, "
                                 "which is not held")
            if kind == HANDING_OVER:
                lbs = struct.unpack_from(f"<{n}I", payload, at + 8 * n)
                self.in_doubt.update(zip(ids, lbs))
            else:
                for mover_id in ids:
                    self.in_doubt.pop(mover_id, None)
        elif kind == REMOVE or kind == HANDOVER_OUT:
            if not self.alive.issuperset(ids):
                raise ValueError(f"a {KIND_NAMES[kind]} record takes mover {min(set(ids) - self.alive):X}, "
                                 "which is not held")
            for mover_id in ids:
                self.alive.discard(mover_id)
                self.in_doubt.pop(mover_id, None)
                self.rows.pop(mover_id, None)
                self.specs.pop(mover_id, None)
                self.base.pop(mover_id, None)
        else:
            raise ValueError(f"a record of unknown kind {kind}")

    def movers(self, jump: int) -> list[SavedMover]:
        out = []
        for mover_id in sorted(self.alive):
            row = self.rows.get(mover_id)
            base = self.base.get(mover_id)
            if row is None:
                assert base is not None
                out.append(base if not jump else _with_seq(base, base.handover.seq + jump))
                continue
            buf, seq_at, state_at = row
            (seq,) = _ID.unpack_from(buf, seq_at)
            spec = self.specs.get(mover_id)
            if spec is None:
                assert base is not None
                spec = base.spec
            out.append(saved_mover(mover_id, seq + jump, spec, buf[state_at:state_at + MOVER_STATE_BYTES]))
        return out


def saved_mover(mover_id: int, seq: int, spec: MoverSpec, engine_state: bytes, source: str = "log") -> SavedMover:
    """A mover of a log as the state file keeps it (the hand-over map, the spec, velocity and engine state)."""
    st = decode_state(engine_state)
    names = [n for n in spec.state if n not in ("Contact", "OnWalkable")]
    if st.contact:
        names.append("Contact")
    if st.on_walkable:
        names.append("OnWalkable")
    handover = HandoverRequest(
        mover_id, seq, replace(spec, state=names), st.position, st.contact_plane if st.contact else None,
        st.contact_plane_cell_id if st.contact else None, st.sliding_normal if st.sliding else None,
        st.water_contact, source)
    entry: dict[str, Any] = _encode_handover(handover)
    entry["registered_mover"] = encode_mover_spec(spec)
    entry["velocity"] = encode_vec(st.velocity)
    entry["engine_state"] = engine_state
    return SavedMover(handover, spec, st.velocity, entry, engine_state)


def _with_seq(m: SavedMover, seq: int) -> SavedMover:
    entry = dict(m.entry)
    entry["seq"] = seq
    return replace(m, handover=replace(m.handover, seq=seq), entry=entry)


def replay(saved: list[SavedMover], records: Iterable[bytes], jump: int = 0) -> list[SavedMover]:
    """`saved` with `records` applied in order; ValueError for a record that does not fit."""
    r = _Replay(saved)
    for payload in records:
        r.apply(payload)
    return r.movers(jump)


def load_saved(path: str | Path, discard_bad: bool = False) -> Loaded:
    """FILE and its logs (see the module's docstring); StateFileError when they cannot be restored in full
    (without `discard_bad`)."""
    path = Path(path)
    saved, first = read_snapshot(path)
    logs = journal_files(path)
    stale = [p for g, p in logs.items() if g < first]
    todo = [(g, p) for g, p in logs.items() if g >= first]
    if saved is None and not todo:
        return Loaded(None, first, [], stale)
    state = _Replay(saved or [])
    jump = 0
    records = 0
    replayed: list[Path] = []
    for k, (_generation, p) in enumerate(todo):
        replayed.append(p)
        bad: str | None = None
        scan = JournalScan(p, check_run)
        before = state.records
        try:
            for item in scan.items():
                if isinstance(item, FrameRun):
                    state.apply_run(item)
                else:
                    state.apply(item)
            f = scan.file
            jump = max(jump, f.budget + 1 if f.budget else 0)
            if f.torn is not None:
                log.warning("state log %s: dropped a torn tail (%s, %d bytes): a record cut off by the stop",
                            p, f.torn, f.torn_bytes)
        except JournalCorrupt as e:
            bad = str(e)
        except OSError as e:
            bad = f"state log {p}: {e}"
        except (ValueError, struct.error) as e:
            bad = f"state log {p}: record {state.records - before + 1} cannot be replayed: {e}"
        records += state.records - before
        if bad is None:
            continue
        if not discard_bad:
            raise StateFileError(f"{bad} ({_HINT})")
        # the movers as of the last whole record; every later byte may have held moves answered since
        rest = [q for _g, q in todo[k:]]
        unread = sum(q.stat().st_size for q in rest)
        jump = max(jump, DEFAULT_BUDGET + 1) + unread // _MOVE_BYTES
        for q in rest:
            log.warning("%s; set aside as %s, the movers restored as of the record before the damage", bad,
                        set_aside(q))
        replayed = replayed[:-1]
        break
    generation = max([first] + [g + 1 for g, _p in todo])
    return Loaded(state.movers(jump), generation, replayed, stale, jump, records, dict(state.in_doubt))
