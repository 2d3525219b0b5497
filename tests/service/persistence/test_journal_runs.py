"""A long log read fast (service/persistence/frame_runs.py's runs of frames checked at once by folded
checksums, service/persistence/state_replay.py's moves in bulk) gives what reading it record by record gives:
each mover's last row (its seq and state), the records' order kept across registers, removes and hand-overs;
a torn tail dropped; damage in the middle of a run refused, or set aside as of the record before it."""

from __future__ import annotations

import logging
import os
import random
import struct
import zlib
from pathlib import Path

import msgpack
import numpy as np
import pytest

from engine.geometry import Position, Vec3
from service.ownership import Ownership
from service.persistence import state_layout
from service.persistence.frame_runs import check_run, fold_equal, shift
from service.persistence.journal import HEADER_BYTES, FrameRun, Journal, JournalScan, journal_path
from service.persistence.journal_records import (
    HANDING_OVER,
    MOVES,
    RECORD_HEAD,
    REGISTER,
    REMOVE,
    decode_state,
    mover_state_bytes,
)
from service.persistence.state_file import StateFileError
from service.persistence.state_layout import regroup_state
from service.persistence.state_replay import load_saved
from service.protocol.codec import encode_mover_spec
from support.service_harness import demo_world, human, start_on_ground

A, B, C = 0xA1, 0xB2, 0xC3
SPEC = msgpack.packb([encode_mover_spec(human())], use_bin_type=True)


def _template() -> bytes:
    """A real mover's 224-byte state on the demo world's ground (its x at bytes 32..39)."""
    world = demo_world()
    pos = start_on_ground(world, 0xA9B40001, 50.0, 50.0)
    engine_id = world.add_mover(human(), Position.at(pos.cell_id, pos.origin + Vec3(0.0, 0.0, 0.0)))
    try:
        return mover_state_bytes(world.movers[engine_id])
    finally:
        world.remove_mover(engine_id)


TEMPLATE = _template()


def state(x: float) -> bytes:
    """The template with origin x = `x`: each move's state tells which move it was."""
    b = bytearray(TEMPLATE)
    struct.pack_into("<d", b, 32, x)
    return bytes(b)


def register(mover_id: int, x: float = 1.0) -> bytes:
    return RECORD_HEAD.pack(REGISTER, 1) + struct.pack("<QQ", mover_id, 0) + state(x) + SPEC


def moves(rows: list[tuple[int, int, float]]) -> bytes:
    """A MOVES record of (id, seq, x) rows."""
    n = len(rows)
    return (RECORD_HEAD.pack(MOVES, n) + struct.pack(f"<{n}Q", *[r[0] for r in rows])
            + struct.pack(f"<{n}Q", *[r[1] for r in rows]) + b"".join(state(r[2]) for r in rows))


def remove(mover_id: int) -> bytes:
    return RECORD_HEAD.pack(REMOVE, 1) + struct.pack("<Q", mover_id)


def handing_over(mover_id: int, landblock: int) -> bytes:
    return RECORD_HEAD.pack(HANDING_OVER, 1) + struct.pack("<QI", mover_id, landblock)


def write_log(tmp_path: Path, records: list[bytes]) -> Path:
    """FILE's log of generation 0, written by the log's writer under `always` (budget 0: no seq is raised)."""
    state_path = tmp_path / "m.state"
    j = Journal(state_path, 0, "always")
    for r in records:
        j.append(r)
    j.close()
    return state_path


def frame_offsets(path: Path) -> list[int]:
    """Where each frame starts, read with the documented layout (length u32 at the frame's start)."""
    data = path.read_bytes()
    out, off = [], HEADER_BYTES
    while off < len(data):
        out.append(off)
        off += 12 + struct.unpack_from("<I", data, off)[0]
    return out


def restored(loaded_movers: list | None) -> dict[int, tuple[int, float]]:
    """Each mover's seq and the x its state holds."""
    assert loaded_movers is not None
    return {m.handover.id: (m.handover.seq, decode_state(m.engine_state).position.origin.x) for m in loaded_movers}


# -- the folded checksum ---------------------------------------------------------------------------------------
def test_shift_gives_the_crc_of_a_concatenation() -> None:
    rng = random.Random(5)
    for n in (1, 4, 8, 245, 257, 24017):
        a, b = rng.randbytes(rng.randrange(1, 300)), rng.randbytes(n)
        got = int(shift(np.array([zlib.crc32(a)], dtype=np.uint32), n)[0]) ^ zlib.crc32(b)
        assert got == zlib.crc32(a + b)


def test_the_fold_sees_damage_even_when_two_frames_are_damaged_alike() -> None:
    rng = random.Random(7)
    parts = [rng.randbytes(245) for _ in range(64)]
    crcs = np.array([zlib.crc32(p) for p in parts], dtype=np.uint32)
    assert fold_equal(crcs, 245, zlib.crc32(b"".join(parts)))
    damaged = [bytearray(p) for p in parts]
    for i in (3, 40):  # the same bit of the same byte in two parts: an XOR of the parts would not see it
        damaged[i][100] ^= 0x10
    assert not fold_equal(crcs, 245, zlib.crc32(b"".join(damaged)))
    with pytest.raises(ValueError):
        fold_equal(crcs[:48], 245, 0)


# -- the scan ----------------------------------------------------------------------------------------------------
def test_runs_give_the_same_records_as_reading_frame_by_frame(tmp_path: Path) -> None:
    rng = random.Random(11)
    records = [register(A), register(B)] + [moves([(A, k + 1, float(k))]) for k in range(300)]
    records += [moves([(B, k, 1.0)] * rng.choice((1, 2))) for k in range(40)]  # lengths that vary
    records += [moves([(A, 1000 + k, 2.0)] * 3) for k in range(70)]
    path = journal_path(write_log(tmp_path, records), 0)
    data = path.read_bytes()
    expected = [data[o + 12:o + 12 + struct.unpack_from("<I", data, o)[0]] for o in frame_offsets(path)]
    assert expected == records
    assert list(JournalScan(path)) == records  # frame by frame
    assert list(JournalScan(path, check_run)) == records
    items = list(JournalScan(path, check_run).items())
    assert any(isinstance(i, FrameRun) for i in items)  # (a run is read before the next item, as it says)


# -- replay --------------------------------------------------------------------------------------------------------
def test_a_mover_moved_a_thousand_times_comes_back_as_its_last_move(tmp_path: Path) -> None:
    records = [register(A), register(B), register(C)]
    records += [moves([(A, k, float(k))]) for k in range(1, 1001)]  # single moves
    seq_b = 0
    for _ in range(10):  # records of 100 rows, each row B's
        rows = [(B, seq_b + i + 1, 5000.0 + seq_b + i) for i in range(100)]
        seq_b += 100
        records.append(moves(rows))
    records.append(moves([(B, 7, 9.0)] * 99 + [(C, 42, 77.0)]))  # an earlier seq, but the last row: it wins
    loaded = load_saved(write_log(tmp_path, records))
    assert loaded.records == len(records)
    assert loaded.jump == 0
    got = restored(loaded.movers)
    assert got[A] == (1000, 1000.0)
    assert got[B] == (7, 9.0)
    assert got[C] == (42, 77.0)


def test_registers_removes_and_hand_overs_keep_their_order(tmp_path: Path) -> None:
    records = [register(A), register(B)]
    records += [moves([(A, k, float(k)), (B, k, -float(k))] * 8) for k in range(1, 41)]  # a run of 16-row records
    records.append(handing_over(A, 0xA9B5FFFF))
    records += [moves([(B, 100 + k, 100.0 + k)]) for k in range(40)]  # a run without A: A stays in doubt
    records.append(remove(B))
    records.append(register(B, 3.0))  # a new B: registered again, from seq 0
    records.append(handing_over(B, 0xA9B5FFFF))
    records += [moves([(B, k, 200.0 + k)]) for k in range(1, 33)]  # moved after: it stayed here
    loaded = load_saved(write_log(tmp_path, records))
    got = restored(loaded.movers)
    assert got == {A: (40, 40.0), B: (32, 232.0)}
    assert loaded.in_doubt == {A: 0xA9B5FFFF}


def test_runs_of_registers_and_removes_are_applied_record_by_record(tmp_path: Path) -> None:
    """Frames of one length that are not all moves (forty registers, then thirty removes) make runs too."""
    ids = list(range(0x100, 0x128))
    records = [register(i, float(i)) for i in ids]
    records += [moves([(i, 5, 2.0 * i) for i in ids[k:k + 20]]) for k in range(0, 40, 20)]
    records += [remove(i) for i in ids[:30]]
    state_path = write_log(tmp_path, records)
    assert any(isinstance(item, FrameRun) for item in JournalScan(journal_path(state_path, 0), check_run).items())
    loaded = load_saved(state_path)
    assert restored(loaded.movers) == {i: (5, 2.0 * i) for i in ids[30:]}
    with_a_stranger = [*records[:40], remove(ids[0]), *[moves([(ids[1], k, 1.0)]) for k in range(1, 40)],
                       moves([(ids[0], 1, 1.0)]), *[moves([(ids[1], k, 1.0)]) for k in range(40, 60)]]
    again = tmp_path / "again"
    again.mkdir()
    with pytest.raises(StateFileError, match="record 81 cannot be replayed: a moves record changes mover 100,"):
        load_saved(write_log(again, with_a_stranger))


def test_a_move_of_a_removed_mover_in_a_run_is_refused_or_set_aside_as_of_the_record_before(tmp_path: Path) -> None:
    records = [register(A), register(B), remove(B)]
    records += [moves([(A, k, float(k))]) for k in range(1, 50)]
    records.append(moves([(B, 1, 1.0)]))  # record 53: B is not held
    records += [moves([(A, k, float(k))]) for k in range(50, 70)]
    state_path = write_log(tmp_path, records)
    with pytest.raises(StateFileError, match="record 53 cannot be replayed: a moves record changes mover B2"):
        load_saved(state_path)
    loaded = load_saved(state_path, discard_bad=True)
    assert restored(loaded.movers) == {A: (49 + loaded.jump, 49.0)}
    assert loaded.records == 52


def test_a_torn_tail_after_a_run_is_dropped_and_said(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    records = [register(A)] + [moves([(A, k, float(k))]) for k in range(1, 101)]
    state_path = write_log(tmp_path, records)
    path = journal_path(state_path, 0)
    size = path.stat().st_size
    os.truncate(path, size - 100)  # the last record cut off
    with caplog.at_level(logging.WARNING, logger="acphys.service"):
        loaded = load_saved(state_path)
    assert restored(loaded.movers) == {A: (99, 99.0)}
    assert "dropped a torn tail" in caplog.text


@pytest.mark.parametrize("where", ["payload", "header", "two alike"])
def test_damage_inside_a_run_stops_the_start_at_its_record(tmp_path: Path, where: str) -> None:
    records = [register(A)] + [moves([(A, k, float(k))]) for k in range(1, 201)]
    state_path = write_log(tmp_path, records)
    path = journal_path(state_path, 0)
    starts = frame_offsets(path)
    data = bytearray(path.read_bytes())
    bad = starts[61]  # the frame of record 62 (A's 61st move)
    if where == "payload":
        data[bad + 12 + 100] ^= 0x01
    elif where == "header":
        data[bad + 4] ^= 0x01  # its payload's checksum as written: its header's own checksum fails
    else:  # the same bit of two frames: an XOR of the frames would not see it
        data[bad + 12 + 100] ^= 0x01
        data[starts[93] + 12 + 100] ^= 0x01
    path.write_bytes(bytes(data))
    with pytest.raises(StateFileError, match=f"at byte {bad} "):
        load_saved(state_path)
    loaded = load_saved(state_path, discard_bad=True)
    assert restored(loaded.movers) == {A: (60 + loaded.jump, 60.0)}
    assert loaded.jump > 0


def test_a_single_process_restart_reads_its_log_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The regroup before a single process starts has nothing to move when only FILE's own layout is there:
    it leaves the log to the start (which reads it), rather than replay it too."""
    state_path = write_log(tmp_path, [register(A)] + [moves([(A, 1, 1.0)])])
    calls: list[object] = []
    monkeypatch.setattr(state_layout, "load_saved", lambda *a, **k: calls.append(a))
    assert regroup_state(str(state_path), 1, [Ownership()]) is None
    assert calls == []
