"""SIGKILL at random moments (benchmarks/durability_kills.py): each `--state-sync` policy keeps its promise
(docs/protocol.md, "Durability"). A dozen kills here, bounded in time; the benchmark (`python3 -m benchmarks
--only durability`) runs many more. And a hand-over pair killed in turn mid-traffic: every mover exists
exactly once afterwards, and no seq is answered twice."""

from __future__ import annotations

import os
import random
import signal
import threading
import time
from pathlib import Path

import msgpack
import pytest
import zenoh

from benchmarks.durability_kills import WINDOW_S, run_kills
from clients import Client
from clients.demo.world import global_to_cell
from clients.errors import AcphysError
from support.cluster_files import cluster_pair
from support.service_harness import ServiceProcess, demo_world, human, raw_session, start_on_ground


def test_always_loses_nothing_answered_across_random_kills() -> None:
    run = run_kills("always", kills=6, seed=11)
    assert run.violations == []
    assert run.kills == 6 and run.requests >= 12  # requests were answered between the kills (slowly under coverage)
    assert run.lost_moves == [0] * 6


@pytest.mark.parametrize("policy", ["every-second", "never"])
def test_every_second_and_never_lose_nothing_older_than_the_window(policy: str) -> None:
    run = run_kills(policy, kills=4, seed=12 if policy == "every-second" else 13)
    assert run.violations == []  # among them: nothing answered more than WINDOW_S before a kill is lost
    assert run.kills == 4 and run.requests >= 8
    assert max(run.lost_age_s) <= WINDOW_S


def _holders(session: zenoh.Session, mover_id: int) -> int:
    """How many instances answer a Get of the mover (by Zenoh id: an instance owning two keys counts once)."""
    replies = session.get("acphys/lb/*/get", payload=msgpack.packb({"v": 1, "id": mover_id}),
                          target=zenoh.QueryTarget.ALL, consolidation=zenoh.ConsolidationMode.NONE, timeout=3.0)
    return len({str(r.replier_id.zid) for r in replies if r.ok is not None})


def test_a_hand_over_pair_killed_in_turn_keeps_every_mover_once(tmp_path: Path) -> None:
    a_cluster, b_cluster = cluster_pair(tmp_path)
    a_args = [*a_cluster, "--state", str(tmp_path / "a.state"), "--state-interval", "3600"]
    b_args = [*b_cluster, "--state", str(tmp_path / "b.state"), "--state-interval", "3600"]
    world = demo_world()
    rng = random.Random(21)
    procs = {"a": ServiceProcess(own="A9B4,A9B5", extra=a_args), "b": ServiceProcess(own="AAB4,AAB5", extra=b_args)}
    procs["a"].start()
    procs["b"].start()
    session = raw_session(procs["a"].endpoint, procs["b"].endpoint)
    answered: dict[int, int] = {}  # the highest seq answered for each mover
    try:
        with Client(session=session, timeout=3.0) as c:
            c.wait_ready(instances=2, timeout=20.0)
            movers = []
            for k in range(4):  # on A's side of the A9B4 | AAB4 border (x 192), 6 m apart
                cell, x, y = global_to_cell(190.0, 30.0 + 6.0 * k)
                movers.append(c.register(human(), start_on_ground(world, cell, x, y)).id)
            time.sleep(WINDOW_S)  # the registers synced: every kill from here on must keep every mover
            for kill in range(4):
                stop = threading.Event()

                def traffic(stop: threading.Event = stop) -> None:  # over the border and back, each in turn
                    for step in range(100000):
                        if stop.is_set():
                            return
                        mover_id = movers[step % len(movers)]
                        dx = 1.5 if (step // len(movers)) % 4 < 2 else -1.5
                        try:
                            st = c.move(mover_id, offset=(dx, 0.0, 0.0), velocity=(0.0, 0.0, 0.0))
                        except AcphysError:
                            return
                        answered[mover_id] = max(answered.get(mover_id, 0), st.seq)

                runner = threading.Thread(target=traffic, daemon=True)
                runner.start()
                time.sleep(rng.uniform(0.5, 1.5))
                victim = procs["a" if kill % 2 == 0 else "b"]
                victim.kill()  # SIGKILL, mid-traffic: often mid-hand-over
                stop.set()
                runner.join(30.0)
                assert not runner.is_alive()
                victim.start()
                c.wait_ready(instances=2, timeout=20.0)
                for mover_id in movers:
                    assert _holders(session, mover_id) == 1, (kill, hex(mover_id))
                    c.find(mover_id)
                    # the first answer after the kill is above every seq answered before it
                    seq = c.move(mover_id, offset=(0.0, 0.1, 0.0)).seq
                    assert seq > answered[mover_id], (kill, hex(mover_id))
                    answered[mover_id] = seq
    finally:
        session.close()
        for p in procs.values():
            p.kill()


def test_a_killed_two_worker_service_restarted_as_one_process_keeps_its_logs_moves(tmp_path: Path) -> None:
    """The moves live only in the workers' logs (each worker's state file was written at its start): the
    parent and its workers are killed, and a single process regroups both workers' files with their logs."""
    state = tmp_path / "movers.state"
    world = demo_world()
    answered = {}
    with ServiceProcess(extra=["--workers", "2", "--state", str(state), "--state-sync", "always"]) as s:
        with Client([s.endpoint], timeout=10.0) as c:
            (health,) = c.wait_ready()
            for mover_id, (gx, gy) in {0x201: (40.0, 40.0), 0x202: (250.0, 40.0)}.items():  # one per worker
                cell, x, y = global_to_cell(gx, gy)
                st = c.register(human(), start_on_ground(world, cell, x, y), mover_id=mover_id)
                for _ in range(5):
                    st = c.step(mover_id, (0.0, 0.6, 0.0), 0.2)
                answered[mover_id] = st
        assert s.proc is not None
        for worker in health["worker_processes"]:  # SIGKILL, each (the parent's death would stop them cleanly)
            os.kill(worker["pid"], signal.SIGKILL)
        os.kill(s.proc.pid, signal.SIGKILL)  # before it starts them again
        s.proc.wait(10)
    logs = sorted(p.name for p in tmp_path.iterdir() if ".journal-" in p.name)
    assert logs == ["movers.state.worker-0-of-2.journal-0", "movers.state.worker-1-of-2.journal-0"]
    with ServiceProcess(extra=["--state", str(state)]) as s:
        with Client([s.endpoint], timeout=10.0) as c:
            c.wait_ready()
            for mover_id, st in answered.items():
                got, _spec = c.get(mover_id)
                assert got.seq == st.seq == 5  # always: nothing answered lost, and no seq raised
                assert got.position.origin == st.position.origin and got.position.cell_id == st.position.cell_id
    assert not [p for p in tmp_path.iterdir() if p.name.startswith("movers.state.worker-") and "regrouped" not in p.name]
