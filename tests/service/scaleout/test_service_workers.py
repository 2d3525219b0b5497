"""`python -m service --workers 2`: one service face, two engine processes behind a Zenoh router.

The demo world's four landblocks split west/east between the workers
(A9B4, A9B5 | AAB4, AAB5), so a mover walking east across x = 192 changes
worker. What a client sees must not show it: one Health and one Stats
reply, every move answered with the next seq and the state one engine
alone computes, states published in seq order.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from clients import Client, MoverState
from support.cluster_files import cluster_pair
from support.shared_data import needs_shared
from engine.geometry import Vec3
from service.persistence.journal import DEFAULT_BUDGET
from support.service_harness import (
    ROOT,
    ServiceProcess,
    child_env,
    comparable,
    demo_world,
    free_port,
    prime_states,
    wait_until,
)
from test_service_scaleout import ZERO, _walk_on_ground


def _pid_gone(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    return False


@pytest.fixture(scope="module")
def service() -> Iterator[ServiceProcess]:
    with ServiceProcess(extra=["--workers", "2"]) as s:
        yield s


@pytest.fixture()
def client(service: ServiceProcess) -> Iterator[Client]:
    with Client([service.endpoint], timeout=10.0) as c:
        c.wait_ready()
        yield c


def test_one_face_health_stats_and_landblocks(client: Client) -> None:
    (health,) = client.health()  # one reply for the whole service
    assert health["status"] == "ok" and health["workers"] == 2 and health["workers_ok"] == 2
    procs = health["worker_processes"]
    assert [p["owned"] for p in procs] == [[0xA9B4, 0xA9B5], [0xAAB4, 0xAAB5]]
    assert len({p["instance"] for p in procs} | {health["instance"]}) == 3  # three Zenoh sessions
    # what the service understands, as a single instance announces it (docs/protocol.md, Health)
    assert health["protocol"] == 1 and health["publish"] == ["each", "batch"]
    assert health["move_forms"] == ["move", "moves", "columns"]
    assert health["queries"] == ["sight", "ray", "ground", "place", "path", "random_point"]
    (stats,) = client.stats()
    assert stats["workers"] == 2 and stats.instance == health.instance
    (lbs,) = client.landblocks()
    assert lbs["owned"] == "*" and lbs["loaded"] == [0xA9B4, 0xA9B5, 0xAAB4, 0xAAB5]


def test_acphys_stats_shows_the_workers(service: ServiceProcess, client: Client) -> None:
    r = subprocess.run([sys.executable, "-m", "clients", "stats", "--connect", service.endpoint], cwd=ROOT,
                       env=child_env(), capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.count("instance ") == 1 + 2  # the service, then each worker's line
    assert "workers       2, 2 answering" in r.stdout
    pids = [p["pid"] for p in client.health()[0]["worker_processes"]]
    assert all(f"ok, pid {p}," in r.stdout for p in pids), r.stdout


def test_a_mover_walks_across_the_workers_split(client: Client) -> None:
    (before,) = client.stats()
    world = demo_world()
    st, mid = _walk_on_ground(client, world, 180.0, 100.0)
    assert st.landblock == 0xA9B4
    got: list[MoverState] = []
    lock = threading.Lock()

    def on_state(s: MoverState) -> None:
        with lock:
            got.append(s)

    path = []
    with client.subscribe(on_state, st.id):
        base = prime_states(client, st.id, lambda: list(got))
        with lock:
            got.clear()
        for k, dx in enumerate([1.0] * 25 + [-1.0] * 25):  # east into AAB4 (the other worker), then back west
            st = client.move(st.id, offset=(dx, 0.0, 0.0), velocity=ZERO)
            cur = world.mover_state(mid).position
            direct = world.move(mid, cur.moved(Vec3(dx, 0.0, 0.0)), Vec3(*ZERO))
            assert st.seq == base + k + 1  # one more per move, whichever worker answered
            assert comparable(st) == comparable(direct)  # the state carried over unchanged
            path.append(st.landblock)
        assert wait_until(lambda: len(got) >= 50, timeout=10.0), len(got)
    assert 0xAAB4 in path and path[-1] == 0xA9B4
    assert [s.seq for s in got] == list(range(base + 1, base + 51))  # published in seq order, none twice
    (after,) = client.stats()
    assert after["handovers"]["out"] - before["handovers"]["out"] == 2  # west to east and back
    assert after["handovers"]["in"] - before["handovers"]["in"] == 2
    assert after["moves"] - before["moves"] >= 50
    client.remove(st.id)


def test_sigterm_stops_every_worker_cleanly() -> None:
    with ServiceProcess(extra=["--workers", "2"]) as s:
        with Client([s.endpoint], timeout=10.0) as c:
            (health,) = c.wait_ready()
            pids = [p["pid"] for p in health["worker_processes"]]
            st, _ = _walk_on_ground(c, demo_world(), 30.0, 30.0)
            assert st.seq == 10
        assert s.stop(signal.SIGTERM) == 0
        assert all(_pid_gone(p) for p in pids), pids


def test_a_dead_worker_is_reported() -> None:
    """With `--worker-restarts 0` a worker that dies stays dead: Health says so, the other serves on."""
    with ServiceProcess(extra=["--workers", "2", "--worker-restarts", "0"]) as s:
        with Client([s.endpoint], timeout=10.0) as c:
            (health,) = c.wait_ready()
            victim = health["worker_processes"][1]
            os.kill(victim["pid"], signal.SIGKILL)
            assert wait_until(lambda: c.health()[0]["status"] == "degraded", timeout=10.0)
            (health,) = c.health()
            assert health["workers"] == 2 and health["workers_ok"] == 1
            assert health["worker_processes"][1]["status"] == "dead"
            assert health["worker_processes"][1]["exit_code"] == -signal.SIGKILL
            assert health["worker_processes"][1]["restarts"] == 0
            # the other worker still serves its landblocks
            st, _ = _walk_on_ground(c, demo_world(), 30.0, 30.0)
            assert st.landblock == 0xA9B4
        assert wait_until(lambda: any("worker 1" in ln and "died" in ln for ln in s.output), timeout=5.0)
        assert s.stop(signal.SIGTERM) == 1  # the exit status says a worker failed
        assert _pid_gone(health["worker_processes"][0]["pid"])


def test_a_dead_worker_is_started_again_with_its_movers(tmp_path: Path) -> None:
    """SIGKILL to the east worker: the parent logs it, starts it again with the same landblocks, and its
    `--state` file gives the mover back with its seq; moves go on from there. The exit status still says
    that a worker died."""
    state = tmp_path / "movers.state"
    with ServiceProcess(extra=["--workers", "2", "--state", str(state), "--state-interval", "0.2"]) as s:
        with Client([s.endpoint], timeout=10.0) as c:
            (health,) = c.wait_ready()
            victim = health["worker_processes"][1]
            assert victim["owned"] == [0xAAB4, 0xAAB5] and victim["restarts"] == 0
            st, _ = _walk_on_ground(c, demo_world(), 250.0, 30.0)
            assert st.landblock == 0xAAB4 and st.seq == 10
            saved = Path(f"{state}.worker-1-of-2")
            assert wait_until(lambda: saved.exists() and saved.stat().st_size > 0, timeout=10.0)
            time.sleep(1.5)  # the log's sync after the last move (--state-sync every-second)
            os.kill(victim["pid"], signal.SIGKILL)
            assert wait_until(lambda: c.health()[0]["status"] == "degraded", timeout=10.0)

            def started_again() -> bool:
                (h,) = c.health()
                w = h["worker_processes"][1]
                return h["status"] == "ok" and w["restarts"] == 1 and w["pid"] != victim["pid"]

            assert wait_until(started_again, timeout=60.0)
            (back, *_rest) = c.get(st.id)
            # seq goes on above any the killed worker may have answered after its last sync
            assert back.seq == 10 + DEFAULT_BUDGET + 1 and back.position.origin == st.position.origin
            assert c.step(st.id, ZERO, 0.2).seq == back.seq + 1
            # the west worker never stopped
            assert c.health()[0]["worker_processes"][0]["pid"] == health["worker_processes"][0]["pid"]
        assert any("worker 1: starting it again in 0.5 s (restart 1 of at most 5)" in ln for ln in s.output), s.output[-20:]
        assert s.stop(signal.SIGTERM) == 1


def test_x_stripe_instances_hand_over(tmp_path: Path) -> None:
    """The rule form between two separate instances of a cluster: X up to A9 on one, AA and up on the other."""
    a_args, b_args = cluster_pair(tmp_path)
    with ServiceProcess(own="x=00-A9", extra=a_args), ServiceProcess(own="x=AA-FF", extra=b_args) as b:
        with Client([b.endpoint], timeout=10.0) as c:
            c.wait_ready(instances=2)
            owned = sorted((lb["owned"]["x_min"], lb["owned"]["x_max"]) for lb in c.landblocks())
            assert owned == [(0x00, 0xA9), (0xAA, 0xFF)]
            world = demo_world()
            st, mid = _walk_on_ground(c, world, 185.0, 60.0)
            for k in range(12):
                st = c.move(st.id, offset=(1.0, 0.0, 0.0), velocity=ZERO)
                cur = world.mover_state(mid).position
                assert comparable(st) == comparable(world.move(mid, cur.moved(Vec3(1.0, 0.0, 0.0)), Vec3(*ZERO)))
                assert st.seq == 11 + k
            assert st.landblock == 0xAAB4
            assert sum(s["handovers"]["in"] for s in c.stats()) == 1


@needs_shared
def test_dat_dir_workers_split_by_x_stripes() -> None:
    """A dat directory's landblocks are not known in advance: `--own x=A8-AA --workers 2` gives the
    workers the X stripes A8 and A9-AA, and a mover walking east out of A8B4 changes worker."""
    from engine import open_dat_world

    from support.service_harness import human, start_on_ground
    from support.shared_data import DATS

    dats = DATS / "rolling"
    assert (dats / "client_cell_1.dat").is_file(), f"the shared reference dats are missing at {dats}"
    svc = ServiceProcess(own="x=A8-AA", extra=["--workers", "2"])
    at = svc.args.index("--scene")
    svc.args[at:at + 2] = ["--dat-dir", str(dats)]
    with svc, Client([svc.endpoint], timeout=10.0) as c:
        (health,) = c.wait_ready()
        assert [p["owned"] for p in health["worker_processes"]] == [{"x_min": 0xA8, "x_max": 0xA8},
                                                                    {"x_min": 0xA9, "x_max": 0xAA}]
        world = open_dat_world(str(dats))
        x, y = 185.0, 100.0
        cell = 0xA8B40000 | (int(x // 24) * 8 + int(y // 24) + 1)
        start = start_on_ground(world, cell, x, y)
        st = c.register(human(), start)
        mid = world.add_mover(human(), start)
        for _ in range(10):
            st = c.step(st.id, ZERO, 0.2)
            assert comparable(st) == comparable(world.step(mid, Vec3(*ZERO), 0.2))
        for k in range(15):
            st = c.move(st.id, offset=(1.0, 0.0, 0.0), velocity=ZERO)
            cur = world.mover_state(mid).position
            assert comparable(st) == comparable(world.move(mid, cur.moved(Vec3(1.0, 0.0, 0.0)), Vec3(*ZERO)))
            assert st.seq == 11 + k
        assert st.landblock == 0xA9B4
        (lbs,) = c.landblocks()
        w0, w1 = lbs["worker_processes"]
        assert 0xA9B4 in w1["loaded"] and 0xA9B4 not in w0["loaded"]  # loaded on demand by the worker that owns it
        (stats,) = c.stats()
        assert stats["handovers"]["out"] == 1 and stats["handovers"]["in"] == 1


def test_ctrl_c_on_the_terminal_stops_the_service_cleanly() -> None:
    """Ctrl-C signals the terminal's whole process group: the parent alone is in it and stops the
    workers itself (none is counted as died), exit status 0."""
    svc = ServiceProcess(extra=["--workers", "2"])
    proc = subprocess.Popen(svc.args, cwd=ROOT, env=child_env(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            text=True, start_new_session=True)  # a process group of its own, as a shell job
    try:
        assert proc.stdout is not None
        lines = []
        for line in proc.stdout:  # bounded: the service prints a few lines, then its ready line or exits
            lines.append(line)
            if "acphys service ready" in line or len(lines) > 200:
                break
        assert "acphys service ready" in lines[-1], "".join(lines)
        with Client([svc.endpoint], timeout=10.0) as c:
            pids = [p["pid"] for p in c.wait_ready()[0]["worker_processes"]]
        os.killpg(proc.pid, signal.SIGINT)
        assert proc.wait(30) == 0
        assert all(_pid_gone(p) for p in pids)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)


def test_a_worker_that_cannot_start_fails_the_service(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """An empty directory is no dat directory: the workers exit, the parent says so and exits 2."""
    r = subprocess.run([sys.executable, "-m", "service", "--dat-dir", str(tmp_path), "--workers", "2",
                        "--listen", f"tcp/127.0.0.1:{free_port()}", "--log-level", "WARNING"],
                       cwd=ROOT, env=child_env(), capture_output=True, text=True, timeout=120)
    assert r.returncode == 2, r.stdout + r.stderr
    assert "cannot start the workers: worker" in r.stderr and "did not start" in r.stderr
    assert "acphys service ready" not in r.stdout
