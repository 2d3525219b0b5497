"""The state log replayed (service/persistence/state_replay.py): a core records every change of every kind
(register, moves of the map and the column form, update, remove); what the log gives back is each mover
as the core holds it, bit for bit, and a mover restored from it moves on as the uninterrupted one does.
Records that do not fit, a damaged log and a torn tail are refused, set aside or dropped as documented."""

from __future__ import annotations

import logging
import struct
from pathlib import Path

import msgpack
import pytest

from benchmarks.standins import SilentBus
from clients.demo.world import global_to_cell
from engine.geometry import Position, Vec3
from engine.world.mover import Mover
from service.protocol.codec import encode_position, encode_state
from service.column_moves import run_columns
from service.protocol.column_request import parse_column_request
from service.core import ServiceCore
from service.persistence.journal import DEFAULT_BUDGET, Journal, journal_files, journal_path
from service.persistence.journal_records import MoverLog, decode_state, mover_state_bytes
from service.protocol.messages import RegisterRequest
from service.ownership import Ownership
from service.protocol.requests import MoveItem
from service.persistence.state_file import StateFileError, restore, write_state
from service.persistence.state_replay import load_saved
from service.stats import ServiceStats
from support.service_harness import demo_world, human, start_on_ground


def _core() -> ServiceCore:
    return ServiceCore(demo_world(), SilentBus(), ownership=Ownership(), instance="test", stats=ServiceStats())


def _register(core: ServiceCore, mover_id: int, gx: float, gy: float, lift: float = 0.0) -> None:
    cell, x, y = global_to_cell(gx, gy)
    pos = start_on_ground(core.world, cell, x, y)
    pos = Position.at(pos.cell_id, pos.origin + Vec3(0.0, 0.0, lift))
    core.register(RegisterRequest(mover_id, human(), pos, None, None))


def _step(core: ServiceCore, mover_id: int, motion: tuple[float, float, float], dt: float) -> None:
    core.move_one(MoveItem("move", mover_id, None, motion=Vec3(*motion), dt=dt), 0.0)


def _columns(core: ServiceCore, ids: list[int], motion: tuple[float, float, float], dt: float) -> None:
    n = len(ids)
    msg = {"v": 1, "kind": "motion", "columns": {
        "id": struct.pack(f"<{n}Q", *ids), "motion": struct.pack(f"<{3 * n}d", *(motion * n)),
        "dt": struct.pack(f"<{n}d", *([dt] * n))}}
    run_columns(core, parse_column_request(msg), 0.0)


def _mover(core: ServiceCore, mover_id: int) -> Mover:
    return core.world.movers[core.movers[mover_id].engine_id]


def _every_kind(core: ServiceCore) -> None:
    """Registers, map and column moves (a mover named twice in one batch), a held-over short step, a fall
    with speed, an update and a remove."""
    _register(core, 0xA1, 60.0, 60.0)
    _register(core, 0xB2, 100.0, 40.0, lift=20.0)  # falls: it has speed when the log ends
    _register(core, 0xC3, 250.0, 30.0)
    for _ in range(3):
        _step(core, 0xA1, (0.0, 0.8, 0.0), 0.2)
        _step(core, 0xB2, (0.0, 0.0, 0.0), 0.2)
    core.move_one(MoveItem("move", 0xC3, None, offset=Vec3(0.5, 0.0, 0.0)), 0.0)
    spec = human()
    spec.step_up_height = 0.3
    core.update(0xA1, spec)
    _columns(core, [0xA1, 0xB2, 0xA1], (0.0, 0.5, 0.0), 0.2)
    core.remove(0xC3)
    _step(core, 0xA1, (0.0, 0.1, 0.0), 0.02)  # shorter than a quantum: held over with its motion


def _logged(tmp_path: Path, policy: str = "always") -> tuple[ServiceCore, Path]:
    state = tmp_path / "m.state"
    core = _core()
    journal = Journal(state, 0, policy)
    core.attach_log(MoverLog(journal))
    _every_kind(core)
    journal.close()
    return core, state


@pytest.mark.parametrize("policy", ["always", "every-second", "never"])
def test_the_log_gives_back_every_mover_as_the_core_holds_it(tmp_path: Path, policy: str) -> None:
    core, state = _logged(tmp_path, policy)
    loaded = load_saved(state)
    assert loaded.movers is not None and loaded.records > 0
    got = {m.handover.id: m for m in loaded.movers}
    assert sorted(got) == [0xA1, 0xB2]  # C3 removed
    jump = 0 if policy == "always" else DEFAULT_BUDGET + 1  # the log was not closed by a clean stop
    for mover_id, m in got.items():
        mover = _mover(core, mover_id)
        assert m.handover.seq == core.movers[mover_id].seq + jump
        assert m.engine_state == mover_state_bytes(mover)
        st = decode_state(m.engine_state or b"")
        assert encode_position(st.position) == encode_position(mover.position) and st.velocity == mover.velocity
        assert (st.held_time, st.held_motion, st.transient) == (mover.held_time, mover.held_motion, mover.transient)
    assert core.movers[0xA1].seq == 6 and core.movers[0xB2].seq == 4  # 3 steps + 2 (A1 named twice) + 1
    assert _mover(core, 0xA1).held_time > 0.0 and _mover(core, 0xB2).velocity.z < 0.0
    assert got[0xA1].spec.step_up_height == 0.3  # the update's spec


def test_a_mover_restored_from_the_log_moves_on_as_the_uninterrupted_one(tmp_path: Path) -> None:
    core, state = _logged(tmp_path)
    loaded = load_saved(state)
    assert loaded.movers is not None
    again = _core()
    restore(again, loaded.movers, state)
    for mover_id in (0xA1, 0xB2):
        for k in range(4):
            motion = Vec3(0.0, 0.8, 0.0)
            a = core.world.step(core.movers[mover_id].engine_id, motion, 0.02 + 0.1 * k)
            b = again.world.step(again.movers[mover_id].engine_id, motion, 0.02 + 0.1 * k)
            assert encode_state(mover_id, 0, a, []) == encode_state(mover_id, 0, b, []), (mover_id, k)
        assert mover_state_bytes(_mover(core, mover_id)) == mover_state_bytes(_mover(again, mover_id))


def test_the_log_is_replayed_on_top_of_the_state_file_and_older_logs_are_ignored(tmp_path: Path) -> None:
    state = tmp_path / "m.state"
    core = _core()
    _register(core, 0xA1, 60.0, 60.0)
    _step(core, 0xA1, (0.0, 0.8, 0.0), 0.2)
    write_state(state, core.snapshot_movers(), "test", journal=3)  # holds logs 0..2
    journal_path(state, 2).write_bytes(b"whatever an old log held: never read")
    journal = Journal(state, 3, "always")
    core.attach_log(MoverLog(journal))
    _step(core, 0xA1, (0.0, 0.8, 0.0), 0.2)
    journal.close()
    loaded = load_saved(state)
    assert loaded.movers is not None and [m.handover.seq for m in loaded.movers] == [2]
    assert loaded.movers[0].engine_state == mover_state_bytes(_mover(core, 0xA1))
    assert loaded.stale == [journal_path(state, 2)] and loaded.replayed == [journal_path(state, 3)]
    assert loaded.generation == 4


def _log(state: Path, *payloads: bytes) -> None:
    j = Journal(state, 0, "always")
    for p in payloads:
        j.append(p)
        j.commit()
    j.close()


def test_a_move_of_a_mover_never_registered_is_refused(tmp_path: Path) -> None:
    state = tmp_path / "m.state"
    core = _core()
    _register(core, 0xA1, 60.0, 60.0)
    log = MoverLog(Journal(state, 0, "always"))
    log.moved(0xDEAD, 1, _mover(core, 0xA1))  # no register record for DEAD
    log.commit()
    log.journal.close()
    with pytest.raises(StateFileError, match="DEAD, which is not held"):
        load_saved(state)


def test_a_register_of_a_mover_held_already_is_refused(tmp_path: Path) -> None:
    state = tmp_path / "m.state"
    core = _core()
    log = MoverLog(Journal(state, 0, "always"))
    core.attach_log(log)
    _register(core, 0xA1, 60.0, 60.0)
    log.journal.close()
    record = journal_path(state, 0).read_bytes()
    journal_path(state, 0).write_bytes(record + record[28:])  # the register record twice
    with pytest.raises(StateFileError, match="A1, which is held already"):
        load_saved(state)


def test_a_damaged_log_stops_the_load_or_is_set_aside_keeping_the_records_before(tmp_path: Path) -> None:
    core, state = _logged(tmp_path)
    path = journal_path(state, 0)
    data = bytearray(path.read_bytes())
    # damage the payload of the third record (the first registers come before it)
    off, starts = 28, []
    while off < len(data):
        starts.append(off)
        off += 12 + struct.unpack_from("<I", data, off)[0]
    data[starts[2] + 12 + 8] ^= 0x10
    path.write_bytes(bytes(data))
    with pytest.raises(StateFileError, match="fails its checksum"):
        load_saved(state)
    assert path.read_bytes() == bytes(data)  # left as it was
    loaded = load_saved(state, discard_bad=True)
    assert loaded.movers is not None
    assert sorted(m.handover.id for m in loaded.movers) == [0xA1, 0xB2]  # the two registers before the damage
    # seqs go on above anything the damaged part could have held (a move takes at least 240 bytes there)
    assert all(m.handover.seq >= DEFAULT_BUDGET + 1 + (len(data) - 28) // 240 for m in loaded.movers)
    assert not path.exists() and [p.name for p in tmp_path.iterdir() if ".bad-" in p.name]
    assert journal_files(state) == {}


def test_a_torn_tail_is_dropped_and_said(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    core, state = _logged(tmp_path)
    path = journal_path(state, 0)
    data = path.read_bytes()
    whole = load_saved(state)
    path.write_bytes(data[:-5])  # the last record (A1's held-over step) cut off
    with caplog.at_level(logging.WARNING, logger="acphys.service"):
        torn = load_saved(state)
    assert any("torn tail" in r.getMessage() and str(path) in r.getMessage() for r in caplog.records)
    assert whole.movers is not None and torn.movers is not None
    a_whole = next(m for m in whole.movers if m.handover.id == 0xA1)
    a_torn = next(m for m in torn.movers if m.handover.id == 0xA1)
    assert a_torn.handover.seq == a_whole.handover.seq - 1  # the last move is not there, the one before is
    assert decode_state(a_torn.engine_state or b"").held_time == 0.0


def test_record_specs_are_msgpack_maps(tmp_path: Path) -> None:
    # the layout the module documents: kind u8, n u32, ids, seqs, states, then the specs as a msgpack array
    state = tmp_path / "m.state"
    core = _core()
    core.attach_log(MoverLog(Journal(state, 0, "always")))
    _register(core, 0xA1, 60.0, 60.0)
    assert core.log is not None
    core.log.journal.close()
    data = journal_path(state, 0).read_bytes()[28 + 12:]
    kind, n = struct.unpack_from("<BI", data, 0)
    mover_id, seq = struct.unpack_from("<QQ", data, 5)
    specs = msgpack.unpackb(data[5 + 16 + 224:], raw=False)
    assert (kind, n, mover_id, seq) == (2, 1, 0xA1, 0) and specs[0]["step_up_height"] == 0.6


def test_a_hand_over_sent_with_no_outcome_logged_is_in_doubt(tmp_path: Path) -> None:
    state = tmp_path / "m.state"
    core = _core()
    log = MoverLog(Journal(state, 0, "always"))
    core.attach_log(log)
    for mover_id, gx in ((0xA1, 60.0), (0xB2, 100.0), (0xC3, 140.0), (0xD4, 20.0)):
        _register(core, mover_id, gx, 60.0)
    log.handing_over(0xA1, 0xAAB4)  # sent, then the kill: did AAB4's owner take it?
    log.handing_over(0xB2, 0xAAB4)
    log.handover_failed(0xB2)  # refused: it stayed
    log.handing_over(0xC3, 0xAAB4)
    log.handed_over(0xC3, 0xAAB4)  # taken: gone from here
    log.handing_over(0xD4, 0xAAB4)
    _step(core, 0xD4, (0.0, 0.5, 0.0), 0.2)  # moved here afterwards: it stayed
    log.journal.close()
    loaded = load_saved(state)
    assert loaded.movers is not None and sorted(m.handover.id for m in loaded.movers) == [0xA1, 0xB2, 0xD4]
    assert loaded.in_doubt == {0xA1: 0xAAB4}


class _WatchedBus(SilentBus):
    """A bus someone listens on, which reads the log at each State published: (the State's seq, the seq the
    log holds for that mover at that moment)."""

    def __init__(self, state: Path) -> None:
        self.state = state
        self.seen: list[tuple[int, int | None]] = []

    def states_watched(self) -> bool:
        return True

    def publish_state(self, mover_id: int, packed_state: bytes) -> None:
        held = {m.handover.id: m.handover.seq for m in load_saved(self.state).movers or []}
        self.seen.append((msgpack.unpackb(packed_state)["seq"], held.get(mover_id)))


def test_under_always_a_state_is_published_only_once_its_record_is_synced(tmp_path: Path) -> None:
    state = tmp_path / "m.state"
    core = _core()
    bus = _WatchedBus(state)
    core.bus = bus
    core.attach_log(MoverLog(Journal(state, 0, "always")))
    _register(core, 0xA1, 60.0, 60.0)
    for _ in range(3):
        _step(core, 0xA1, (0.0, 0.8, 0.0), 0.2)
    _columns(core, [0xA1], (0.0, 0.5, 0.0), 0.2)
    assert bus.seen == [(0, 0), (1, 1), (2, 2), (3, 3), (4, 4)]  # the register's, the steps', the column move's
    assert core.log is not None
    core.log.journal.close()
