"""`--state FILE` across a change of `--workers`: the saved movers go to the files of the new layout's
workers by landblock (service/persistence/state_layout.py), or the start is refused with every file left as it was.

The demo world's four landblocks, split by hand: two workers own A9B4,A9B5 | AAB4,AAB5; three own
A9B4 | A9B5 | AAB4,AAB5; a single process owns all four.
"""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from clients import Client
from clients.demo.world import global_to_cell
from engine.geometry import Position, Vec3
from service.protocol.codec import encode_mover_spec, encode_position
from service.protocol.messages import HANDOVER, HandoverRequest
from service.ownership import Ownership
from service.persistence.state_file import StateFileError, read_state, write_state
from service.persistence.state_layout import layout_paths, regroup_state, saved_files
from support.service_harness import DEMO_SCENE, ROOT, ServiceProcess, child_env, demo_world, free_port, human

_encode = HANDOVER.encode_fn()

A9B4, A9B5, AAB4, AAB5 = 0xA9B4, 0xA9B5, 0xAAB4, 0xAAB5
TWO = [Ownership(frozenset({A9B4, A9B5})), Ownership(frozenset({AAB4, AAB5}))]
THREE = [Ownership(frozenset({A9B4})), Ownership(frozenset({A9B5})), Ownership(frozenset({AAB4, AAB5}))]
#: one mover per landblock of the demo world: id -> (landblock, global x, y)
MOVERS = {0x101: (A9B4, 40.0, 40.0), 0x102: (A9B5, 40.0, 250.0), 0x103: (AAB4, 250.0, 40.0),
          0x104: (AAB5, 250.0, 250.0)}


def _entry(mover_id: int, x: float, y: float, seq: int = 3) -> dict[str, Any]:
    """A state file's map for a mover standing at demo-global (x, y), as a running instance writes it."""
    cell, lx, ly = global_to_cell(x, y)
    req = HandoverRequest(mover_id, seq, human(), Position.at(cell, Vec3(lx, ly, 70.0)), None, None, None, False,
                          "test")
    return {**_encode(req), "registered_mover": encode_mover_spec(human()), "velocity": [0.0, 0.0, -1.5]}


def _write_two_workers(state: Path, seq: int = 3) -> None:
    """The files a `--workers 2` service leaves: its west worker's two movers, its east worker's two."""
    write_state(f"{state}.worker-0-of-2", [_entry(i, x, y, seq) for i, (_lb, x, y) in MOVERS.items() if i <= 0x102], "w0")
    write_state(f"{state}.worker-1-of-2", [_entry(i, x, y, seq) for i, (_lb, x, y) in MOVERS.items() if i > 0x102], "w1")


def _ids(path: Path | str) -> list[int]:
    return sorted(m.handover.id for m in read_state(path) or [])


def _snapshot(d: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in d.iterdir()}


def test_the_files_of_every_layout_are_found_and_nothing_else(tmp_path: Path) -> None:
    state = tmp_path / "movers.state"
    for name in ("movers.state", "movers.state.worker-0-of-2", "movers.state.worker-1-of-2",
                 "movers.state.worker-0-of-2.user-alice", "movers.state.bad-20240101T000000-7",
                 "movers.state.worker-0-of-2.regrouped-20240101T000000-7", "other.state.worker-0-of-2",
                 ".movers.state.123.tmp"):
        (tmp_path / name).write_bytes(b"x")
    assert [p.name for p in saved_files(str(state))] == [
        "movers.state", "movers.state.worker-0-of-2", "movers.state.worker-1-of-2"]
    assert [p.name for p in saved_files(str(state), "alice")] == ["movers.state.worker-0-of-2.user-alice"]
    assert [p.name for p in layout_paths(str(state), 3, 2)] == ["movers.state.worker-0-of-3",
                                                                  "movers.state.worker-1-of-3"]


def test_two_workers_files_go_to_three_workers_by_landblock(tmp_path: Path) -> None:
    state = tmp_path / "movers.state"
    _write_two_workers(state)
    before = {m.handover.id: m.entry for f in ("worker-0-of-2", "worker-1-of-2") for m in read_state(f"{state}.{f}") or []}
    done = regroup_state(str(state), 3, THREE)
    assert done is not None
    assert _ids(f"{state}.worker-0-of-3") == [0x101]  # A9B4
    assert _ids(f"{state}.worker-1-of-3") == [0x102]  # A9B5
    assert _ids(f"{state}.worker-2-of-3") == [0x103, 0x104]  # AAB4, AAB5
    after = {m.handover.id: m.entry for k in range(3) for m in read_state(f"{state}.worker-{k}-of-3") or []}
    assert after == before  # every map carried over unchanged (seq, position, spec, velocity)
    # the old layout's files are renamed aside, not deleted, and are no longer among the state's files
    names = sorted(p.name for p in tmp_path.iterdir())
    assert [n for n in names if ".regrouped-" in n and n.startswith("movers.state.worker-0-of-2")]
    assert [n for n in names if ".regrouped-" in n and n.startswith("movers.state.worker-1-of-2")]
    assert [p.name for p in saved_files(str(state))] == [f"movers.state.worker-{k}-of-3" for k in range(3)]
    # and the new layout, started again, has nothing to move
    assert regroup_state(str(state), 3, THREE) is None


def test_workers_files_go_to_a_single_process_and_back(tmp_path: Path) -> None:
    state = tmp_path / "movers.state"
    _write_two_workers(state)
    assert regroup_state(str(state), 1, [Ownership()]) is not None
    assert _ids(state) == sorted(MOVERS)
    assert regroup_state(str(state), 2, TWO) is not None
    assert _ids(f"{state}.worker-0-of-2") == [0x101, 0x102]
    assert _ids(f"{state}.worker-1-of-2") == [0x103, 0x104]
    assert not state.exists()


def test_a_mover_found_in_two_layouts_keeps_its_latest_copy(tmp_path: Path) -> None:
    """A crash between writing the new layout and setting the old one aside leaves both: the copy with
    the higher seq wins, whichever layout it is in."""
    state = tmp_path / "movers.state"
    _write_two_workers(state, seq=3)
    write_state(f"{state}.worker-2-of-3", [_entry(0x103, 251.0, 40.0, seq=7)], "w2")  # moved on since
    write_state(state, [_entry(0x101, 41.0, 40.0, seq=1)], "single")  # older than the workers' copy
    regroup_state(str(state), 3, THREE)
    seqs = {m.handover.id: m.handover.seq for k in range(3) for m in read_state(f"{state}.worker-{k}-of-3") or []}
    assert seqs == {0x101: 3, 0x102: 3, 0x103: 7, 0x104: 3}
    (m103,) = [m for m in read_state(f"{state}.worker-2-of-3") or [] if m.handover.id == 0x103]
    assert m103.handover.position.origin.x == pytest.approx(251.0 - 192.0)
    assert not state.exists()


def test_a_mover_no_worker_owns_refuses_and_changes_no_file(tmp_path: Path) -> None:
    state = tmp_path / "movers.state"
    _write_two_workers(state)
    before = _snapshot(tmp_path)
    west_only = [Ownership(frozenset({A9B4})), Ownership(frozenset({A9B5}))]
    with pytest.raises(StateFileError) as e:
        regroup_state(str(state), 3, west_only)
    text = str(e.value)
    assert "movers.state.worker-1-of-2" in text and "103" in text and "AAB4" in text and "2 mover(s)" in text
    assert _snapshot(tmp_path) == before


def test_an_unreadable_file_of_the_old_layout_refuses_unless_told_to_discard(tmp_path: Path) -> None:
    state = tmp_path / "movers.state"
    _write_two_workers(state)
    bad = Path(f"{state}.worker-1-of-2")
    bad.write_bytes(bad.read_bytes()[:-20])
    before = _snapshot(tmp_path)
    with pytest.raises(StateFileError) as e:
        regroup_state(str(state), 3, THREE)
    assert str(bad) in str(e.value) and "--state-discard-bad" in str(e.value)
    assert _snapshot(tmp_path) == before
    regroup_state(str(state), 3, THREE, discard_bad=True)
    assert [_ids(f"{state}.worker-{k}-of-3") for k in range(3)] == [[0x101], [0x102], []]
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith("movers.state.worker-1-of-2.bad-")]


def test_the_usual_layout_is_left_alone_unless_a_mover_is_in_another_workers_file(tmp_path: Path) -> None:
    state = tmp_path / "movers.state"
    _write_two_workers(state)
    before = _snapshot(tmp_path)
    assert regroup_state(str(state), 2, TWO) is None
    assert _snapshot(tmp_path) == before
    # the same count with another split (here: --own changed) moves what no longer belongs
    shifted = [Ownership(frozenset({A9B4})), Ownership(frozenset({A9B5, AAB4, AAB5}))]
    assert regroup_state(str(state), 2, shifted) is not None
    assert _ids(f"{state}.worker-0-of-2") == [0x101]
    assert _ids(f"{state}.worker-1-of-2") == [0x102, 0x103, 0x104]


def test_each_users_files_are_regrouped_on_their_own(tmp_path: Path) -> None:
    state = tmp_path / "movers.state"
    write_state(f"{state}.worker-1-of-2.user-alice", [_entry(0x103, 250.0, 40.0)], "w1")
    write_state(f"{state}.worker-0-of-2.user-bob", [_entry(0x101, 40.0, 40.0)], "w0")
    regroup_state(str(state), 1, [Ownership()], user="alice")
    assert _ids(f"{state}.user-alice") == [0x103]
    assert not Path(f"{state}.user-bob").exists() and _ids(f"{state}.worker-0-of-2.user-bob") == [0x101]


def test_serve_refuses_a_regroup_it_cannot_do_and_says_what_to_do(tmp_path: Path) -> None:
    state = tmp_path / "movers.state"
    _write_two_workers(state)
    before = _snapshot(tmp_path)
    r = subprocess.run([sys.executable, "-m", "service", "--scene", str(DEMO_SCENE), "--workers", "3",
                        "--own", "A9B4,A9B5", "--state", str(state), "--listen", f"tcp/127.0.0.1:{free_port()}",
                        "--log-level", "WARNING"], cwd=ROOT, env=child_env(), capture_output=True, text=True, timeout=120)
    assert r.returncode == 2, r.stdout + r.stderr
    assert f"{state}.worker-1-of-2" in r.stderr and "--own" in r.stderr and "no state file was changed" in r.stderr
    assert "Traceback" not in r.stderr and "ready" not in r.stdout
    assert _snapshot(tmp_path) == before


def _register_one_per_landblock(c: Client) -> dict[int, Any]:
    out = {}
    world = demo_world()
    for mover_id, (_lb, x, y) in MOVERS.items():
        cell, lx, ly = global_to_cell(x, y)
        z = world.terrain_height(cell, lx, ly) + 3.0  # in the air: each step falls a little further
        st = c.register(human(), Position.at(cell, Vec3(lx, ly, z)), mover_id=mover_id)
        for _ in range(mover_id - 0x100):  # a different seq each: 1, 2, 3, 4
            st = c.step(st.id, (0.0, 0.0, 0.0), 0.2)
        out[mover_id] = st
    return out


def _every_mover_back(c: Client, saved: dict[int, Any]) -> None:
    for mover_id, st in saved.items():
        got, _spec = c.get(mover_id)
        assert got.seq == st.seq == mover_id - 0x100
        assert encode_position(got.position) == encode_position(st.position)
    (stats,) = c.stats()
    assert stats["movers"] == len(saved)


def test_restart_with_three_workers_then_one_process_brings_every_mover_back(tmp_path: Path) -> None:
    state = tmp_path / "movers.state"
    with ServiceProcess(extra=["--workers", "2", "--state", str(state)]) as s:
        with Client([s.endpoint], timeout=10.0) as c:
            c.wait_ready()
            saved = _register_one_per_landblock(c)
        assert s.stop(signal.SIGTERM) == 0
    assert _ids(f"{state}.worker-0-of-2") == [0x101, 0x102] and _ids(f"{state}.worker-1-of-2") == [0x103, 0x104]
    with ServiceProcess(extra=["--workers", "3", "--state", str(state), "--log-level", "INFO"]) as s:
        with Client([s.endpoint], timeout=10.0) as c:
            (health,) = c.wait_ready()
            assert [p["owned"] for p in health["worker_processes"]] == [[A9B4], [A9B5], [AAB4, AAB5]]
            _every_mover_back(c, saved)
        assert any("4 mover(s)" in ln and "redistributed" in ln for ln in s.output), s.output[-20:]
        assert s.stop(signal.SIGTERM) == 0
    with ServiceProcess(extra=["--state", str(state)]) as s:
        with Client([s.endpoint], timeout=10.0) as c:
            c.wait_ready()
            _every_mover_back(c, saved)
        assert s.stop(signal.SIGTERM) == 0
    assert _ids(state) == sorted(MOVERS)
    assert [p.name for p in saved_files(str(state))] == ["movers.state"]
