"""The state log's framing (service/persistence/journal.py): what is written reads back whole; a record a kill cut off
at the end is dropped and said; damage with records after it is refused, never skipped."""

from __future__ import annotations

import random
import struct
import time
import zlib
from pathlib import Path

import pytest

import service.persistence.journal as journal_module
from service.persistence.journal import HEADER_BYTES, Journal, JournalCorrupt, frame, journal_files, journal_path, read_journal

PAYLOADS = [b"first record", bytes(range(256)) * 3, b"x", b"the last one"]


def _written(tmp_path: Path, policy: str = "always") -> Path:
    j = Journal(tmp_path / "s.state", 4, policy)
    for p in PAYLOADS:
        j.append(p)
        j.commit()
    j.close()
    return journal_path(tmp_path / "s.state", 4)


def _ends(data: bytes) -> list[int]:
    """Where each frame ends, read with the documented layout (length u32 at the frame's start)."""
    out, off = [], HEADER_BYTES
    while off < len(data):
        (length,) = struct.unpack_from("<I", data, off)
        off += 12 + length
        out.append(off)
    return out


@pytest.mark.parametrize("policy", ["always", "every-second", "never"])
def test_records_read_back_whole_and_in_order(tmp_path: Path, policy: str) -> None:
    path = _written(tmp_path, policy)
    f = read_journal(path)
    assert f.records == PAYLOADS and f.torn is None
    assert (f.generation, f.budget) == (4, 0 if policy == "always" else 1 << 20)
    assert journal_files(tmp_path / "s.state") == {4: path}


def test_the_frame_layout_is_the_documented_one() -> None:
    payload = b"abc"
    f = frame(payload)
    head = struct.pack("<II", 3, zlib.crc32(payload))
    assert f == head + struct.pack("<I", zlib.crc32(head)) + payload


_CRC_INPUTS = [b"", b"\x00", b"\xff", bytes(range(240)), random.Random(7).randbytes(1 << 20)]


@pytest.mark.parametrize("data", _CRC_INPUTS, ids=["empty", "zero byte", "ff byte", "240 bytes", "1 MB random"])
def test_the_checksum_is_zlibs_crc32(data: bytes) -> None:
    # whichever implementation the log uses, its values are the CRC-32 zlib computes, alone and chained
    assert journal_module.crc32(data) == zlib.crc32(data)
    for start in (0, 1, 0xCBF43926, 0xFFFFFFFF):
        assert journal_module.crc32(data, start) == zlib.crc32(data, start)
    half = len(data) // 2
    assert journal_module.crc32(data[half:], journal_module.crc32(data[:half])) == zlib.crc32(data)


def test_the_checksum_is_the_standard_crc32() -> None:
    # the CRC-32 check value of the nine digits, as catalogued for CRC-32/ISO-HDLC (the zlib/gzip one)
    assert journal_module.crc32(b"123456789") == 0xCBF43926


def test_the_checksum_is_isals_where_isal_is_installed() -> None:
    isal_zlib = pytest.importorskip("isal.isal_zlib")
    assert journal_module.crc32 is isal_zlib.crc32


def test_a_log_written_with_zlibs_crc32_reads_with_the_journals(tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    # a log written where isal was missing (zlib's crc32) reads where it is installed, and the other way round
    checksum = journal_module.crc32
    (tmp_path / "zlib").mkdir()
    (tmp_path / "own").mkdir()
    monkeypatch.setattr(journal_module, "crc32", zlib.crc32)
    zlib_path = _written(tmp_path / "zlib")
    monkeypatch.setattr(journal_module, "crc32", checksum)
    own_path = _written(tmp_path / "own")
    assert zlib_path.read_bytes() == own_path.read_bytes()
    assert read_journal(zlib_path).records == PAYLOADS
    monkeypatch.setattr(journal_module, "crc32", zlib.crc32)
    assert read_journal(own_path).records == PAYLOADS


def test_a_record_cut_off_anywhere_is_dropped_with_the_ones_before_kept(tmp_path: Path) -> None:
    path = _written(tmp_path)
    data = path.read_bytes()
    ends = _ends(data)
    assert ends[-1] == len(data)
    last_start = ends[-2]
    for cut in range(last_start + 1, len(data)):  # every byte of the last frame, header and payload
        path.write_bytes(data[:cut])
        f = read_journal(path)
        assert f.records == PAYLOADS[:-1], cut
        assert f.torn is not None and f.torn_bytes == cut - last_start, cut


def test_a_cut_header_of_the_file_holds_no_record(tmp_path: Path) -> None:
    path = _written(tmp_path)
    path.write_bytes(path.read_bytes()[:HEADER_BYTES - 5])
    f = read_journal(path)
    assert f.records == [] and f.torn is not None


def test_a_zeroed_tail_counts_as_torn(tmp_path: Path) -> None:
    path = _written(tmp_path)
    data = path.read_bytes()
    path.write_bytes(data + bytes(4096))  # what a power cut can leave past the last write
    f = read_journal(path)
    assert f.records == PAYLOADS and f.torn is not None and f.torn_bytes == 4096


def test_a_damaged_payload_in_the_middle_is_refused(tmp_path: Path) -> None:
    path = _written(tmp_path)
    data = bytearray(path.read_bytes())
    ends = _ends(bytes(data))
    second = ends[0]  # the second frame starts where the first ends
    data[second + 12 + 100] ^= 0x04  # one bit of its payload
    path.write_bytes(bytes(data))
    with pytest.raises(JournalCorrupt) as e:
        read_journal(path)
    assert e.value.offset == second and e.value.records == PAYLOADS[:1]
    assert str(path) in str(e.value) and f"byte {second}" in str(e.value)


def test_a_damaged_length_in_the_middle_is_refused_not_taken_for_a_torn_tail(tmp_path: Path) -> None:
    path = _written(tmp_path)
    data = bytearray(path.read_bytes())
    second = _ends(bytes(data))[0]
    data[second + 2] = 0x7F  # the length now points far past the end of the file
    path.write_bytes(bytes(data))
    with pytest.raises(JournalCorrupt) as e:
        read_journal(path)
    assert e.value.offset == second and e.value.records == PAYLOADS[:1]


def test_a_damaged_last_payload_is_a_torn_tail(tmp_path: Path) -> None:
    # a power cut can leave the last write's pages unwritten while its length reached the disk
    path = _written(tmp_path)
    data = bytearray(path.read_bytes())
    data[-3] ^= 0xFF
    path.write_bytes(bytes(data))
    f = read_journal(path)
    assert f.records == PAYLOADS[:-1] and f.torn is not None


def test_a_file_that_is_not_a_log_is_refused(tmp_path: Path) -> None:
    path = journal_path(tmp_path / "s.state", 0)
    path.write_bytes(b"NOTALOG!" + bytes(40))
    with pytest.raises(JournalCorrupt, match="wrong magic"):
        read_journal(path)


def test_rotate_finishes_one_generation_and_starts_the_next(tmp_path: Path) -> None:
    state = tmp_path / "s.state"
    j = Journal(state, 0, "every-second")
    j.append(b"in zero")
    assert j.rotate() == 1
    j.append(b"in one")
    assert j.close() == 2
    assert read_journal(journal_path(state, 0)).records == [b"in zero"]
    assert read_journal(journal_path(state, 1)).records == [b"in one"]


def test_every_second_writes_within_about_a_second_without_a_commit_sync(tmp_path: Path) -> None:
    state = tmp_path / "s.state"
    j = Journal(state, 0, "every-second", interval=0.05)
    try:
        j.append(b"waiting")
        j.commit()  # gathered in the process: the thread writes it
        for _ in range(500):
            if read_journal(journal_path(state, 0)).records:
                break
            time.sleep(0.01)
        assert read_journal(journal_path(state, 0)).records == [b"waiting"]
    finally:
        j.close()


def test_the_seq_budget_forces_a_sync(tmp_path: Path) -> None:
    state = tmp_path / "s.state"
    j = Journal(state, 0, "every-second", budget=10, interval=3600.0)  # the thread never wakes in this test
    try:
        j.append(b"nine moves", moves=9)
        j.commit()
        assert read_journal(journal_path(state, 0)).records == []
        j.append(b"one more", moves=1)
        j.commit()  # 10 moves not yet durable: written and synced before the reply
        assert read_journal(journal_path(state, 0)).records == [b"nine moves", b"one more"]
    finally:
        j.close()


def test_a_failed_write_leaves_no_half_record_and_is_written_again(tmp_path: Path,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    import errno
    import os

    import service.persistence.journal as journal_module

    state = tmp_path / "s.state"
    j = Journal(state, 0, "always")
    j.append(b"first")
    j.commit()
    real_writev = os.writev

    def half_then_full(fd: int, pieces: list[bytes]) -> int:  # a disk that fills up in the middle of a write
        data = b"".join(pieces)
        os.write(fd, data[:len(data) // 2])
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(journal_module.os, "writev", half_then_full)
    j.append(b"second, which fails")
    with pytest.raises(OSError):
        j.commit()
    assert read_journal(journal_path(state, 0)).records == [b"first"]  # nothing of the second in the file
    monkeypatch.setattr(journal_module.os, "writev", real_writev)
    j.append(b"third")
    j.commit()
    j.close()
    f = read_journal(journal_path(state, 0))
    assert f.records == [b"first", b"second, which fails", b"third"] and f.torn is None


def test_short_writes_go_on_where_they_stopped(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A write that takes only some of the bytes (allowed of any write) leaves the records whole and in order:
    here every writev writes at most 7 bytes, so each stops inside a frame's header or payload."""
    import os

    import service.persistence.journal as journal_module

    real_writev = os.writev
    calls = 0

    def seven_at_most(fd: int, pieces: list[bytes]) -> int:
        nonlocal calls
        calls += 1
        return real_writev(fd, [b"".join(pieces)[:7]])

    state = tmp_path / "s.state"
    j = Journal(state, 0, "always")
    monkeypatch.setattr(journal_module.os, "writev", seven_at_most)
    j.append(b"one", b"two", moves=1)
    j.append(b"a record of thirty-one bytes...", moves=1)
    j.commit()
    monkeypatch.setattr(journal_module.os, "writev", real_writev)
    j.close()
    f = read_journal(journal_path(state, 0))
    assert f.records == [b"onetwo", b"a record of thirty-one bytes..."] and f.torn is None
    # two frames: 12-byte headers, payloads of 6 and 31 bytes: 61 bytes, 7 at a time
    assert calls == 9
