"""The append-only log beside a state file (`acphys serve --state FILE`): framing, writing, reading.

Each request's resolved changes become one record (service/persistence/journal_records.py
says what a record holds), appended to `FILE.journal-G`, where G is the
log's generation: the state file names the first generation it does not
already hold, so a start reads the state file, then every log of that
generation and later, in order (service/persistence/lifecycle.py).

A log file is a 28-byte header, then frames:

    header: b"ACPHYSJ1", generation u64, seq budget u64, crc32 of those 24 bytes u32
    frame:  length u32, crc32 of the payload u32, crc32 of the 8 bytes before it u32, payload

all little-endian. The frame header's own checksum tells a damaged length
(corruption) from a frame the kill cut off (a torn tail: its header is
whole, its payload runs past the end of the file, or fewer than 12 bytes
are left; a tail of zero bytes, as a power cut can leave, counts as torn
too). A torn tail is dropped with a log line: its request was never
answered under `always`, and it lies within the window otherwise. A frame
that fails its checksum with records after it is corruption: reading
refuses it (`JournalCorrupt`), never skips it. A start reads a long log
by runs of frames of one length where it can, each run's checksums checked
at once (service/persistence/frame_runs.py), and frame by frame elsewhere
and wherever a run does not check, which finds the damaged frame.

The writer's policy (`--state-sync`) says when records reach the disk:

- `always`: each request's record is written and fdatasync'ed before its
  reply goes out;
- `every-second`: records are gathered in the process, then framed,
  written and fdatasync'ed by the log's thread once a second (written
  sooner, by that thread, when a megabyte waits; written and synced on the
  request's own thread only when `budget` moves are not yet synced);
- `never`: as every-second, but only written, never synced: the OS writes
  them back when it chooses.

The seq budget: no more than `budget` moves are ever answered beyond what
is durable (the writer syncs before answering more), so after a crash a
restored mover's seq continues at its logged seq + budget + 1, above every
seq answered (0 under `always`, where nothing answered is ever lost).

Why not SQLite in WAL mode (the standard library's sqlite3): measured on
this project's 2-core machine, a request of 100 moves kept as one
transaction upserting 100 rows (id, seq, the 224-byte state) took 350 us
on the calling thread with `synchronous=NORMAL` and 1,650 us with `FULL`,
against 11 us for this log's `append` + `commit` under `every-second`
(the framing and writing then done by the log's thread) and 1,420 us under
`always` (one fdatasync, measured while other work used the disk). A
column batch of 100 moves takes 600 to 900 us in the engine, so SQLite
would have cost 40 % or more of it; the log costs about 3 % on that thread.
"""

from __future__ import annotations

import logging
import mmap
import os
import struct
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final

import numpy as np

__all__ = [
    "POLICIES", "DEFAULT_POLICY", "DEFAULT_BUDGET", "Journal", "JournalCorrupt", "JournalFile",
    "JournalScan", "FrameRun", "RunCheck", "gather", "journal_path", "journal_files", "read_journal", "frame",
]

log = logging.getLogger("acphys.service")

#: the checksum of every header and frame: ISA-L's crc32 (python-isal) where it is installed, else zlib's. The
#: two compute the same CRC-32 (the same values, chained the same way), so a log written with either reads with
#: either; ISA-L's folds with carry-less multiplication, about 0.5 instructions a byte against the 3.9 of zlib
#: 1.2.13 as Debian builds it, which was most of what the log cost a column move (docs/performance.md section 8)
try:
    from isal.isal_zlib import crc32
except ImportError:  # no wheel for this platform: zlib's gives the same values, only slower
    from zlib import crc32

POLICIES: Final = ("every-second", "always", "never")
DEFAULT_POLICY: Final = "every-second"
#: moves that may be answered beyond what is durable (every-second and never): far more than a second's
#: worth on one process, so the limit is reached only when a sync stalls
DEFAULT_BUDGET: Final = 1 << 20

MAGIC: Final = b"ACPHYSJ1"
_HEADER: Final = struct.Struct("<8sQQ")
_HEADER_CRC: Final = struct.Struct("<I")
HEADER_BYTES: Final = _HEADER.size + _HEADER_CRC.size  # 28
_FRAME: Final = struct.Struct("<II")
_FRAME_CRC: Final = struct.Struct("<I")
FRAME_HEAD: Final = _FRAME.size + _FRAME_CRC.size  # 12
_FRAME_HEAD: Final = struct.Struct("<III")  # the three at once, to read
#: the writer writes what is waiting once this much is gathered (every-second and never)
WRITE_AT: Final = 1 << 20
#: the largest payload a frame may declare (a longer one is damage, not a record)
MAX_PAYLOAD: Final = 1 << 30


class JournalCorrupt(ValueError):
    """A log with a damaged record before its end (or a damaged header): it cannot be replayed in full."""

    def __init__(self, path: Path, offset: int, reason: str, records: list[bytes]) -> None:
        super().__init__(f"state log {path}: {reason} at byte {offset} (a damaged record with records after "
                         "it: the log cannot be replayed in full)")
        self.path = path
        self.offset = offset
        #: the payloads of the whole records before the damage
        self.records = records


def journal_path(state: str | Path, generation: int) -> Path:
    """The log of `generation` beside state file `state`."""
    return Path(f"{state}.journal-{generation}")


def journal_files(state: str | Path) -> dict[int, Path]:
    """Every log of `state` present, by generation."""
    base = Path(state)
    prefix = f"{base.name}.journal-"
    try:
        names = os.listdir(base.parent)
    except FileNotFoundError:
        return {}
    out: dict[int, Path] = {}
    for n in names:
        if n.startswith(prefix) and n[len(prefix):].isdigit():
            out[int(n[len(prefix):])] = base.parent / n
    return dict(sorted(out.items()))


def frame(payload: bytes) -> bytes:
    """One frame: the header (length, the payload's crc32, the header's own crc32) and the payload."""
    return b"".join(_framed((payload,)))


def _framed(parts: tuple[bytes, ...]) -> tuple[bytes, ...]:
    """A frame of the payload `parts` (joined), as pieces: the header, its checksum, the parts."""
    crc, size = 0, 0
    for part in parts:
        crc = crc32(part, crc)
        size += len(part)
    head = _FRAME.pack(size, crc)
    return (head, _FRAME_CRC.pack(crc32(head)), *parts)


def _header(generation: int, budget: int) -> bytes:
    head = _HEADER.pack(MAGIC, generation, budget)
    return head + _HEADER_CRC.pack(crc32(head))


@dataclass(slots=True)
class JournalFile:
    """One log as read: its header's values, the payloads of its whole records, and what was dropped."""

    path: Path
    generation: int
    budget: int
    records: list[bytes] = field(default_factory=list)
    #: why a torn tail was dropped (None: the log ended cleanly), and how many bytes it held
    torn: str | None = None
    torn_bytes: int = 0
    size: int = 0


def read_journal(path: Path) -> JournalFile:
    """Read a log whole: JournalCorrupt for damage before its end; a torn tail is dropped (and said)."""
    scan = JournalScan(path)
    records: list[bytes] = []
    try:
        for payload in scan:
            records.append(payload)
    except JournalCorrupt as e:
        e.records = records
        raise
    out = scan.file
    out.records = records
    return out


class JournalScan:
    """A log's records one at a time (memory-mapped: a log of gigabytes is not read into memory at once).
    `file` holds the header's values and, once the iteration ended, what was dropped; JournalCorrupt is
    raised where the damage is (its `records` empty: the caller has the ones before it)."""

    def __init__(self, path: Path, runs: RunCheck | None = None) -> None:
        self.path = path
        self.file = JournalFile(path, -1, 0)
        #: what checks many frames of one length at once (service/persistence/frame_runs.py: check_run), if any
        self.runs = runs

    def __iter__(self) -> Iterator[bytes]:
        for item in self.items():
            if isinstance(item, FrameRun):
                yield from (item.payload(i) for i in range(item.count))
            else:
                yield item

    def items(self) -> Iterator[bytes | FrameRun]:
        """The records in order: each a payload, or (with `runs`) a FrameRun of many frames of one length
        checked at once (a long log of single moves is mostly such runs). A run reads the mapped file: use it
        before the next item, and keep nothing of it that refers to the file (its methods return copies)."""
        path = self.path
        with open(path, "rb") as f:
            size = os.fstat(f.fileno()).st_size
            self.file.size = size
            if size < HEADER_BYTES:
                # killed while the file was being made: it holds no record
                _torn(self.file, 0, f"a header cut off ({size} of {HEADER_BYTES} bytes)")
                return
            with mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ) as data:
                yield from self._records(data, size)

    def _records(self, data: mmap.mmap, size: int) -> Iterator[bytes | FrameRun]:
        path, out = self.path, self.file
        magic, generation, budget = _HEADER.unpack_from(data, 0)
        (crc,) = _HEADER_CRC.unpack_from(data, _HEADER.size)
        if magic != MAGIC:
            raise JournalCorrupt(path, 0, "not an acphys state log (wrong magic)", [])
        if crc != crc32(data[:_HEADER.size]):
            raise JournalCorrupt(path, 0, "the header fails its checksum", [])
        out.generation, out.budget = generation, budget
        off = HEADER_BYTES
        unpack_head = _FRAME_HEAD.unpack_from
        checksum = crc32  # a local, not a global looked up for every record
        runs = self.runs
        length = -1  # the last frame's
        single_until = 0  # a run was tried up to here and failed: frame by frame until then
        while off < size:
            if (runs is not None and off >= single_until and length >= 0 and size - off >= FRAME_HEAD
                    and unpack_head(data, off)[0] == length):  # (the next frame's length, for a start)
                run, checked = runs(data, off, length, size)
                if run is not None:
                    yield run
                    off += run.count * run.stride
                    continue
                single_until = off + checked
            if size - off < FRAME_HEAD:
                _torn(out, off, f"a frame header cut off ({size - off} of {FRAME_HEAD} bytes)")
                return
            length, payload_crc, head_crc = unpack_head(data, off)
            if head_crc != checksum(data[off:off + 8]) or length > MAX_PAYLOAD:
                if _zeros(data, off, size):  # a power cut can leave the end of a file zeroed
                    _torn(out, off, "a tail of zero bytes")
                    return
                raise JournalCorrupt(path, off, "a record's header fails its checksum", [])
            end = off + FRAME_HEAD + length
            if end > size:
                _torn(out, off, f"a record cut off ({size - off - FRAME_HEAD} of {length} bytes)")
                return
            payload = data[off + FRAME_HEAD:end]
            if checksum(payload) != payload_crc:
                if _zeros(data, end, size):  # the last record, its write cut short
                    _torn(out, off, "the last record fails its checksum")
                    return
                raise JournalCorrupt(path, off, "a record fails its checksum", [])
            yield payload
            off = end


@dataclass(frozen=True, slots=True)
class FrameRun:
    """`count` whole frames of one payload `length` laid end to end from byte `offset` of a mapped log, all
    of them checked (their headers and payloads against their checksums: service/persistence/frame_runs.py).
    `heads` holds each frame's first bytes (its 12-byte header and the first bytes of its payload), copied
    in one pass. Its methods copy out of the file, so nothing they return keeps the mapping open."""

    data: mmap.mmap
    offset: int
    count: int
    length: int
    heads: np.ndarray[Any, np.dtype[np.uint8]]

    @property
    def stride(self) -> int:
        return FRAME_HEAD + self.length

    def payload(self, i: int) -> bytes:
        at = self.offset + i * self.stride + FRAME_HEAD
        return self.data[at:at + self.length]

    def column(self, at: int, width: int) -> np.ndarray[Any, np.dtype[np.uint8]]:
        """Bytes `at` to `at + width` of every payload, one row a frame (a copy)."""
        if at < 0 or at + width > self.length:
            raise ValueError(f"bytes {at} to {at + width} of a {self.length}-byte payload")
        if FRAME_HEAD + at + width <= self.heads.shape[1]:
            return self.heads[:, FRAME_HEAD + at:FRAME_HEAD + at + width].copy()
        return gather(self.data, self.offset + FRAME_HEAD + at, self.count, self.stride, width)


#: a check of the frames of one payload length from an offset on (data, offset, length, file size): a run of
#: them, or None, and how many bytes need not be tried again
RunCheck = Callable[[mmap.mmap, int, int, int], "tuple[FrameRun | None, int]"]


def gather(data: mmap.mmap, offset: int, count: int, stride: int, width: int) -> np.ndarray[Any, np.dtype[np.uint8]]:
    """`width` bytes from `offset` and every `stride` bytes on, `count` times, as rows (a copy: one element a
    row, which numpy copies far faster than a row of single bytes)."""
    view = np.ndarray((count,), np.dtype(f"V{width}"), data, offset, (stride,))
    try:
        return view.copy().view(np.uint8).reshape(count, width)
    finally:
        del view


def _zeros(data: mmap.mmap, offset: int, size: int) -> bool:
    """Whether everything from `offset` to `size` is zero bytes (or nothing)."""
    step = 1 << 20
    for at in range(offset, size, step):
        chunk = data[at:min(size, at + step)]
        if chunk.count(0) != len(chunk):
            return False
    return True


def _torn(out: JournalFile, offset: int, reason: str) -> None:
    out.torn = f"{reason} at byte {offset}"
    out.torn_bytes = out.size - offset


class Journal:
    """The log being written: one file at a time, records appended by the engine thread (one `append`s
    per request, then `commit`), written and synced by the policy; `rotate` starts the next generation."""

    def __init__(self, state: str | Path, generation: int, policy: str = DEFAULT_POLICY,
                 budget: int = DEFAULT_BUDGET, interval: float = 1.0) -> None:
        if policy not in POLICIES:
            raise ValueError(f"--state-sync must be one of {', '.join(POLICIES)}, got {policy!r}")
        self.state = Path(state)
        self.policy = policy
        self.always = policy == "always"
        #: moves answered beyond what is durable, at most (0 under always)
        self.budget = 0 if self.always else budget
        self.interval = interval
        self.generation = generation
        self._lock = threading.Lock()  # the pending records and the counters
        self._io = threading.Lock()  # the file: one writer at a time, in order
        #: records not yet written, each its payload in parts (framed as they are written)
        self._pending: list[tuple[bytes, ...]] = []
        self._pending_bytes = 0
        self._pending_moves = 0  # in the pending records
        self._unsynced_moves = 0  # taken for writing, not yet on disk (synced; under never, written)
        self._fd = -1
        self._failed: str | None = None
        self._open(generation)
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._thread: threading.Thread | None = None
        if not self.always:
            self._thread = threading.Thread(target=self._flush_loop, name="acphys-journal", daemon=True)
            self._thread.start()
        #: counters for the stats and the benchmark
        self.records = 0
        self.syncs = 0

    @property
    def path(self) -> Path:
        return journal_path(self.state, self.generation)

    def _open(self, generation: int) -> None:
        path = journal_path(self.state, generation)
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC | os.O_APPEND, 0o600)
        try:
            os.write(fd, _header(generation, self.budget))
            os.fsync(fd)
            _fsync_dir(path.parent)
        except BaseException:
            os.close(fd)
            raise
        self._fd = fd
        self.generation = generation

    # -- the engine thread -----------------------------------------------------------------------------
    def append(self, *parts: bytes, moves: int = 0) -> None:
        """Queue one record, its payload given in parts: framed (checksummed) and written in order, under
        `every-second` and `never` by the log's thread, so the engine thread spends no time on either."""
        size = 0
        for part in parts:
            size += len(part)
        with self._lock:
            self._pending.append(parts)
            self._pending_bytes += size
            self._pending_moves += moves
            big = self._pending_bytes >= WRITE_AT
        self.records += 1
        if big and self._thread is not None:
            self._wake.set()

    def commit(self, durable: bool = False) -> None:
        """The end of a request, before its reply: under `always` (or when `durable`, whatever the policy: a
        hand-over) its records are written and synced when this returns; else they are left to the log's
        thread, unless the seq budget is spent: then they are on disk (synced; under never, written) first."""
        if self.always or durable:
            self._write(sync=True)
            return
        # (pending read first: a write taking records between the two reads counts them twice, never not at all)
        if self._pending_moves + self._unsynced_moves >= self.budget:
            self._write(sync=self.policy != "never")

    def sync(self) -> None:
        """Write and fdatasync everything appended so far."""
        self._write(sync=True)

    # -- writing ---------------------------------------------------------------------------------------
    def _write(self, sync: bool) -> None:
        with self._io:
            with self._lock:
                records, self._pending = self._pending, []
                self._unsynced_moves += self._pending_moves
                moves = self._pending_moves
                self._pending_moves = 0
                self._pending_bytes = 0
            if self._fd < 0:
                return
            start = -1
            try:
                if records:
                    start = os.lseek(self._fd, 0, os.SEEK_END)
                    _write_all(self._fd, [b for parts in records for b in _framed(parts)])
                if sync:
                    os.fdatasync(self._fd)
                    self.syncs += 1
                    with self._lock:  # every record taken so far is written (the io lock is held)
                        self._unsynced_moves = 0
                elif self.policy == "never":
                    with self._lock:
                        self._unsynced_moves -= moves
            except OSError as e:
                # (a full disk, say) nothing of these records stays in the file, and they wait to be written
                # again, first: the log never holds half a record before a later one
                if start >= 0:
                    try:
                        os.ftruncate(self._fd, start)
                    except OSError:
                        pass
                with self._lock:
                    self._pending[:0] = records
                    self._pending_moves += moves
                    self._unsynced_moves -= moves
                if self._failed is None:
                    log.error("cannot write the state log %s: %s", self.path, e)
                self._failed = str(e)
                raise
            if self._failed is not None:
                log.warning("the state log %s is written again", self.path)
                self._failed = None

    def _flush_loop(self) -> None:
        """Once a second: write (and under every-second sync) what waits; write sooner when much waits."""
        next_tick = time.monotonic() + self.interval
        while not self._stop.is_set():
            self._wake.wait(max(0.0, next_tick - time.monotonic()))
            self._wake.clear()
            if self._stop.is_set():
                return
            tick = time.monotonic() >= next_tick
            if tick:
                next_tick = time.monotonic() + self.interval
            try:
                self._write(sync=tick and self.policy == "every-second")
            except OSError:
                pass  # said once by _write; the next second tries again

    # -- generations -------------------------------------------------------------------------------------
    def rotate(self) -> int:
        """Finish this generation (written and synced whatever the policy) and start the next; its number.
        Called between two requests (the engine lock held), so that a snapshot taken then holds exactly the
        records of the generations before it."""
        self._write(sync=True)
        with self._io:
            old = self._fd
            self._fd = -1
            os.close(old)
            self._open(self.generation + 1)
        return self.generation

    def close(self) -> int:
        """Write and sync what is left, stop the thread, close the file; the next generation's number (the
        one a final snapshot names: this generation is then wholly in it)."""
        self._stop.set()
        self._wake.set()
        if self._thread is not None:
            self._thread.join()
        try:
            self._write(sync=True)
        finally:
            with self._io:
                if self._fd >= 0:
                    os.close(self._fd)
                self._fd = -1
        return self.generation + 1


#: buffers one writev takes at most (IOV_MAX: 1024 on Linux and the BSDs)
_IOV_MAX: Final = 1024


def _write_all(fd: int, pieces: list[bytes]) -> None:
    """Write `pieces` in order, as if joined, with writev: the records' bytes are not first copied into one
    buffer (a megabyte at a time under every-second). A short write goes on where it stopped."""
    i, n = 0, len(pieces)
    while i < n:
        done = os.writev(fd, pieces[i:i + _IOV_MAX])
        while i < n and done >= len(pieces[i]):
            done -= len(pieces[i])
            i += 1
        if done:  # stopped inside piece i: the rest of it first
            pieces[i] = pieces[i][done:]


def _fsync_dir(path: Path) -> None:
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
