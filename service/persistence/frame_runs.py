"""Many frames of the state log checked at once (numpy): how a start reads a long run of frames of one length
without a Python step per frame (`check_run`, given to service/persistence/journal.py's JournalScan).

The log's checksum is the CRC-32 of zlib (and ISA-L): reflected polynomial 0xEDB88320, register preset to
all ones, result inverted. The CRC of a concatenation follows from its parts' CRCs: crc(A || B) =
Z_len(B)(crc(A)) ^ crc(B), where Z_n (appending n zero bytes) is linear over GF(2) in the 32 bits (what
zlib's crc32_combine computes). So the CRC of K messages laid end to end, computed once over their bytes
by the C routine, must equal the fold of the K CRCs their frames claim (`fold_equal`: a tree of log2(K)
numpy steps, each a table look-up per part). Each part is shifted by a different power of x, so damage in
several frames cancels out no more often than a CRC-32 misses damage in one message (about 2^-32, and
never for a burst of up to 32 bits). A failed fold says only that some frame of the run is bad: the
caller then checks the run frame by frame, which finds which one.
"""

from __future__ import annotations

import mmap
from functools import lru_cache
from typing import Final

import numpy as np
from numpy.typing import NDArray

from service.persistence.journal import FRAME_HEAD, FrameRun, gather

try:  # the log's own checksum (service/persistence/journal.py says why ISA-L's)
    from isal.isal_zlib import crc32
except ImportError:
    from zlib import crc32

__all__ = ["RUN_MIN", "check_run", "fold_equal", "shift"]

U32 = NDArray[np.uint32]

_POLY: Final = 0xEDB88320
_ONES: Final = 0xFFFFFFFF


def _byte_table() -> list[int]:
    """The CRC's byte table: each byte value carried through eight steps of the register."""
    out = []
    for i in range(256):
        c = i
        for _ in range(8):
            c = (c >> 1) ^ _POLY if c & 1 else c >> 1
        out.append(c)
    return out


_T0: Final = _byte_table()
#: Z_1 (one zero byte) column by column: the register's bit k after one zero byte goes in
_ONE: Final = tuple((1 << k >> 8) ^ _T0[(1 << k) & 0xFF] for k in range(32))


def _apply(cols: tuple[int, ...], v: int) -> int:
    """The 32x32 GF(2) matrix with columns `cols` times the bit vector `v`."""
    out, k = 0, 0
    while v:
        if v & 1:
            out ^= cols[k]
        v >>= 1
        k += 1
    return out


@lru_cache(maxsize=256)
def _columns(n: int) -> tuple[int, ...]:
    """Z_n as 32 columns: Z_2m is Z_m twice (the fold's lengths double level by level, so each is one
    squaring of the one before)."""
    if n == 1:
        return _ONE
    if n % 2 == 0:
        half = _columns(n // 2)
        return tuple(_apply(half, c) for c in half)
    rest = _columns(n - 1)
    return tuple(_apply(rest, c) for c in _ONE)


@lru_cache(maxsize=64)
def _operator(n: int) -> tuple[U32, U32]:
    """Z_n as two 65536-entry tables, of the low and of the high 16 bits of a CRC."""
    cols = _columns(n)
    halves = []
    for base in (0, 16):
        t = np.zeros(1 << 16, dtype=np.uint32)
        for j in range(16):  # entries [2^j, 2^(j+1)) are those below with bit j set
            t[1 << j:2 << j] = t[:1 << j] ^ np.uint32(cols[base + j])
        halves.append(t)
    return halves[0], halves[1]


def shift(crc: U32, n: int) -> U32:
    """Z_n of each CRC (little-endian uint32): crc(A || B) == shift(crc(A), len(B)) ^ crc(B)."""
    lo, hi = _operator(n)
    v = np.ascontiguousarray(crc, dtype=np.uint32).view(np.uint16).reshape(-1, 2)
    out: U32 = lo.take(v[:, 0])
    out ^= hi.take(v[:, 1])
    return out


def fold_equal(parts: U32, length: int, whole: int) -> bool:
    """Whether `whole` is the CRC of len(parts) messages of `length` bytes laid end to end, each with the CRC
    in `parts` (len(parts) a power of two)."""
    k = len(parts)
    if k == 0 or k & (k - 1):
        raise ValueError(f"a fold takes a power of two of parts, not {k}")
    p = parts
    while len(p) > 1:
        p = shift(p[0::2], length) ^ p[1::2]
        length *= 2
    return int(p[0]) == whole


#: the fewest frames of one length checked as a run, and the most bytes one run covers (power-of-two counts of
#: frames: the fold of their checksums pairs them level by level)
RUN_MIN: Final = 16
RUN_BYTES: Final = 1 << 26
#: the bytes of each payload a run copies with the frames' headers (a record's head and first id)
RUN_PREFIX: Final = 16
#: the CRC of any 8 bytes followed by their own CRC (little-endian): the same for all (a CRC's residue)
_HEADER_RESIDUE: Final = crc32(crc32(bytes(8)).to_bytes(4, "little"), crc32(bytes(8)))


def check_run(data: mmap.mmap, off: int, length: int, size: int) -> tuple[FrameRun | None, int]:
    """The frames of payload `length` from `off` on, as many as a power of two allows (at least RUN_MIN, at
    most RUN_BYTES), when every one of them is whole and checks: None else (the caller reads them frame by
    frame, which says where the damage or the tear is), with the bytes it need not try again.

    Checked for all frames at once (the fold above): their first 8 header bytes, laid end to end, against the
    fold of the header checksums; then the frames' bytes as they lie, against the fold of what each frame's
    CRC must be, crc(header || payload) = Z_length(crc(header)) ^ crc(payload): a
    12-byte header that ends in the CRC of its first 8 bytes has one CRC whatever they are (_HEADER_RESIDUE),
    and crc(payload) is the CRC the header claims. So nothing is copied but the headers."""
    stride = FRAME_HEAD + length
    if (size - off) // stride < RUN_MIN:
        return None, size - off
    fits = max(RUN_MIN, RUN_BYTES // stride)
    most = min((size - off) // stride, 1 << (fits.bit_length() - 1))  # (no more than one run takes)
    heads = gather(data, off, most, stride, FRAME_HEAD + min(length, RUN_PREFIX))
    words = heads[:, :FRAME_HEAD].copy().view(np.dtype("<u4"))  # length, payload crc, header crc
    other = np.flatnonzero(words[:, 0] != length)
    count = int(other[0]) if len(other) else most
    if count < RUN_MIN:
        return None, (count + 1) * stride
    count = 1 << (count.bit_length() - 1)
    ok = fold_equal(words[:count, 2], 8, crc32(heads[:count, :8].copy()))
    if ok:
        with memoryview(data) as whole, whole[off:off + count * stride] as frames:
            got = crc32(frames)
        residue = shift(np.array([_HEADER_RESIDUE], dtype=np.uint32), length)[0]
        ok = fold_equal(words[:count, 1] ^ residue, stride, got)
    if not ok:
        return None, count * stride
    return FrameRun(data, off, count, length, heads[:count]), count * stride
