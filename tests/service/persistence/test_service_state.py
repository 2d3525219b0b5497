"""Durability: `--state FILE` keeps every mover across a restart; a damaged file stops the start."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import msgpack
import pytest

from clients import Client, ServiceError
from clients.demo.world import global_to_cell
from engine.geometry import Position, Vec3
from service.protocol.codec import encode_plane, encode_position
from service.persistence.journal import DEFAULT_BUDGET, journal_files, read_journal
from service.persistence.state_file import read_state
from support.service_harness import (
    DEMO_SCENE,
    ROOT,
    ServiceProcess,
    child_env,
    comparable,
    demo_world,
    human,
    start_on_ground,
    wait_until,
)

ZERO = (0.0, 0.0, 0.0)


def _state_args(path: Path, *more: str) -> list[str]:
    return ["--state", str(path), *more]


def test_restart_keeps_movers_seq_contact_and_velocity(tmp_path: Path) -> None:
    state = tmp_path / "movers.state"
    world = demo_world()  # the engine alongside: what the movers must be after the restart
    cell, x, y = global_to_cell(60.0, 60.0)
    ground = start_on_ground(world, cell, x, y)
    cell2, x2, y2 = global_to_cell(100.0, 40.0)
    high = Position.at(cell2, Vec3(x2, y2, world.terrain_height(cell2, x2, y2) + 30.0))
    cell3, x3, y3 = global_to_cell(250.0, 30.0)  # level ground
    level = start_on_ground(world, cell3, x3, y3)
    with ServiceProcess(extra=_state_args(state)) as svc:
        with Client([svc.endpoint]) as c:
            c.wait_ready()
            walker = c.register(human(), ground, mover_id=0x5001)
            faller = c.register(human(), high, mover_id=0x5002)
            rester = c.register(human(), level, mover_id=0x5003)
            w, f, r = world.add_mover(human(), ground), world.add_mover(human(), high), world.add_mover(human(), level)
            for _ in range(8):  # the walker lands and walks; the faller falls (it has speed when we stop)
                walker = c.step(walker.id, (0.0, 1.0, 0.0), 0.2)
                world.step(w, Vec3(0.0, 1.0, 0.0), 0.2)
            for _ in range(3):
                faller = c.step(faller.id, ZERO, 0.2)
                world.step(f, Vec3(*ZERO), 0.2)
            for _ in range(4):  # the rester settles: on level ground it slides with no direction, a zero normal
                rester = c.step(rester.id, ZERO, 0.2)
                world.step(r, Vec3(*ZERO), 0.2)
            assert walker.on_walkable and not faller.contact
            assert "Sliding" in rester.result.transient_state and rester.result.sliding_normal == Vec3(0.0, 0.0, 0.0)
        assert svc.stop(signal.SIGTERM) == 0
    saved = read_state(state)
    assert saved is not None and sorted(m.handover.id for m in saved) == [0x5001, 0x5002, 0x5003]
    with ServiceProcess(extra=_state_args(state)) as svc:
        with Client([svc.endpoint]) as c:
            c.wait_ready()
            got_w, spec_w = c.get(0x5001)
            got_f, _ = c.get(0x5002)
            assert (got_w.seq, got_f.seq) == (walker.seq, faller.seq) == (8, 3)
            assert encode_position(got_w.position) == encode_position(walker.position)
            assert encode_position(got_f.position) == encode_position(faller.position)
            assert got_w.contact and got_w.on_walkable and encode_plane(got_w.contact_plane) == encode_plane(walker.contact_plane)
            assert spec_w["state"] == ["IsPlayer"]  # the spec as registered, not the contact it had
            # the next steps are the uninterrupted engine's: velocity (still falling) and contact came back
            for _ in range(3):
                assert comparable(c.step(0x5001, (0.0, 1.0, 0.0), 0.2)) == \
                    comparable(world.step(w, Vec3(0.0, 1.0, 0.0), 0.2))
                assert comparable(c.step(0x5002, ZERO, 0.2)) == comparable(world.step(f, Vec3(*ZERO), 0.2))
                assert comparable(c.step(0x5003, (0.0, 1.0, 0.0), 0.2)) == \
                    comparable(world.step(r, Vec3(0.0, 1.0, 0.0), 0.2))
            assert c.get(0x5002)[0].seq == 6 and c.get(0x5003)[0].seq == 7


@pytest.mark.parametrize("sync", ["always", "every-second"])
def test_a_kill_loses_no_answered_move_and_reuses_no_seq(tmp_path: Path, sync: str) -> None:
    state = tmp_path / "movers.state"
    cell, x, y = global_to_cell(40.0, 40.0)
    with ServiceProcess(extra=_state_args(state, "--state-sync", sync)) as svc:
        with Client([svc.endpoint]) as c:
            c.wait_ready()
            st = c.register(human(), Position.at(cell, Vec3(x, y, 60.0)), mover_id=0x6001)
            st = c.move(st.id, offset=(0.5, 0.0, 0.0))
            if sync == "every-second":  # past the second's sync (the state file is written only every 10 s)
                assert wait_until(lambda: sum(len(read_journal(p).records) for p in journal_files(state).values())
                                  == 2, timeout=10.0)  # the register and the move
        svc.kill()  # SIGKILL: no shutdown save
    with ServiceProcess(extra=_state_args(state)) as svc:
        with Client([svc.endpoint]) as c:
            c.wait_ready()
            got, _ = c.get(0x6001)
            assert encode_position(got.position) == encode_position(st.position)
            if sync == "always":  # nothing answered can have been lost: the seq goes on where it was
                assert got.seq == 1
            else:  # moves answered after the last sync could have been lost: seq goes on above any of them
                assert got.seq == 1 + DEFAULT_BUDGET + 1
            assert c.move(0x6001, offset=(0.5, 0.0, 0.0)).seq == got.seq + 1


def _serve(state: Path, *more: str) -> subprocess.CompletedProcess[str]:
    """Start a service that must refuse to start (it would otherwise run until the timeout)."""
    args = [sys.executable, "-m", "service", "--scene", str(DEMO_SCENE), "--listen", "tcp/127.0.0.1:0",
            "--log-level", "WARNING", "--state", str(state), *more]
    return subprocess.run(args, cwd=ROOT, env=child_env(), capture_output=True, text=True, timeout=60)


def _saved_file(tmp_path: Path) -> Path:
    state = tmp_path / "movers.state"
    cell, x, y = global_to_cell(40.0, 40.0)
    with ServiceProcess(extra=_state_args(state)) as svc:
        with Client([svc.endpoint]) as c:
            c.wait_ready()
            for k in range(3):
                c.register(human(), Position.at(cell, Vec3(x + k, y, 60.0)), mover_id=0x7000 + k)
    assert read_state(state) is not None
    return state


@pytest.mark.parametrize("damage", ["truncated", "flipped", "not_msgpack", "other_version"])
def test_a_damaged_state_file_stops_the_start(tmp_path: Path, damage: str) -> None:
    state = _saved_file(tmp_path)
    data = state.read_bytes()
    if damage == "truncated":
        data = data[: len(data) * 2 // 3]
    elif damage == "flipped":  # one byte inside a mover: only the checksum can tell
        i = len(data) - 40
        data = data[:i] + bytes([data[i] ^ 0x01]) + data[i + 1:]
    elif damage == "not_msgpack":
        data = b"\xc1" + data
    else:
        top = msgpack.unpackb(data, raw=False)
        top["v"] = 2
        data = msgpack.packb(top, use_bin_type=True)
    state.write_bytes(data)
    run = _serve(state)
    assert run.returncode == 2, run.stdout + run.stderr
    assert str(state) in run.stderr and "--state-discard-bad" in run.stderr
    assert "ready" not in run.stdout
    assert state.read_bytes() == data  # left as it was, for whoever repairs it


def test_discard_bad_starts_empty_and_keeps_the_bad_file_aside(tmp_path: Path) -> None:
    state = _saved_file(tmp_path)
    data = state.read_bytes()[:-10]
    state.write_bytes(data)
    with ServiceProcess(extra=_state_args(state, "--state-discard-bad")) as svc:
        with Client([svc.endpoint]) as c:
            c.wait_ready()
            with pytest.raises(ServiceError) as e:
                c.get(0x7000)
            assert e.value.kind in ("unknown_mover",)
    aside = [p for p in tmp_path.iterdir() if p.name.startswith("movers.state.bad-")]
    assert len(aside) == 1 and aside[0].read_bytes() == data


def test_a_mover_the_instance_cannot_take_stops_the_start(tmp_path: Path) -> None:
    # saved by an instance owning everything, restarted owning only AAB4: the movers in A9B4 have no home here
    state = _saved_file(tmp_path)
    run = _serve(state, "--own", "AAB4")
    assert run.returncode == 2 and "7000" in run.stderr and "does not own" in run.stderr, run.stderr


def test_a_log_damaged_before_its_end_stops_the_start_or_is_set_aside(tmp_path: Path) -> None:
    state = tmp_path / "movers.state"
    cell, x, y = global_to_cell(40.0, 40.0)
    with ServiceProcess(extra=_state_args(state, "--state-sync", "always")) as svc:
        with Client([svc.endpoint]) as c:
            c.wait_ready()
            first = c.register(human(), Position.at(cell, Vec3(x, y, 60.0)), mover_id=0x8001)
            for _ in range(4):
                c.move(first.id, offset=(0.5, 0.0, 0.0))
        svc.kill()  # the moves are in the log only
    (log,) = journal_files(state).values()
    data = bytearray(log.read_bytes())
    records = read_journal(log).records
    assert len(records) == 5  # the register and four moves
    # one bit of the third record's payload (after the 28-byte header and the first two frames)
    third = 28 + sum(12 + len(r) for r in records[:2])
    data[third + 12 + 40] ^= 0x01
    log.write_bytes(bytes(data))
    run = _serve(state)
    assert run.returncode == 2, run.stdout + run.stderr
    assert str(log) in run.stderr and f"byte {third}" in run.stderr and "--state-discard-bad" in run.stderr
    assert log.read_bytes() == bytes(data)  # left as it was
    with ServiceProcess(extra=_state_args(state, "--state-discard-bad")) as svc:
        with Client([svc.endpoint]) as c:
            c.wait_ready()
            got, _ = c.get(0x8001)
            # as of the record before the damage: the register and the first move; the seq raised above
            # anything the rest of the log could have held
            assert got.position.origin.x == x + 0.5
            assert got.seq > 4
    assert [p.name for p in tmp_path.iterdir() if ".journal-" in p.name and ".bad-" in p.name]
