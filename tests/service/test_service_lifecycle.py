"""Clean shutdown on SIGINT/SIGTERM, and push-back when the queue is full."""

from __future__ import annotations

import signal
import threading
import time
from typing import Any

import msgpack
import pytest
import zenoh

from clients import Client
from clients.demo.world import global_to_cell
from engine.geometry import Position, Vec3
from service.protocol.wire import MAX_BATCH
from support.service_harness import ServiceProcess, human, raw_session, wait_until


def _register(c: Client, gx: float = 40.0, gy: float = 40.0) -> int:
    cell, x, y = global_to_cell(gx, gy)
    return c.register(human(), Position.at(cell, Vec3(x, y, 60.0))).id


class Collector:
    """Replies to many concurrent queries, counted per query."""

    def __init__(self) -> None:
        self.replies: dict[int, list[tuple[bool, Any]]] = {}
        self.answered_at: dict[int, float] = {}  # time.monotonic() of each query's (last) reply
        self.finished: set[int] = set()
        self.lock = threading.Lock()

    def send(self, session: zenoh.Session, n: int, key: str, payload: bytes, timeout: float = 30.0) -> None:
        self.replies[n] = []

        def on_reply(r: zenoh.Reply) -> None:
            if r.ok is not None:
                item = (True, msgpack.unpackb(r.ok.payload.to_bytes(), raw=False))
            else:
                raw = r.err.payload.to_bytes()
                try:
                    item = (False, msgpack.unpackb(raw, raw=False))
                except Exception:
                    item = (False, {"error": {"kind": "transport", "message": raw.decode("utf-8", "replace")}})
            with self.lock:
                self.replies[n].append(item)
                self.answered_at[n] = time.monotonic()

        def on_done() -> None:
            with self.lock:
                self.finished.add(n)

        session.get(key, zenoh.handlers.Callback(on_reply, on_done), payload=payload, timeout=timeout)


def _batch(mover_id: int, n: int, dx: float = 0.001) -> bytes:
    """`n` moves of one mover, `dx` east then back west, over and over."""
    return msgpack.packb({"v": 1, "moves": [{"id": mover_id, "offset": [dx if k % 2 == 0 else -dx, 0, 0]}
                                             for k in range(n)]})


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_signal_stops_cleanly_with_status_zero(sig: int) -> None:
    svc = ServiceProcess().start()
    try:
        with Client([svc.endpoint]) as c:
            c.wait_ready()
            mover = _register(c)
            assert c.move(mover, offset=(0.5, 0.0, 0.0)).ok
        assert svc.stop(sig, timeout=20.0) == 0
    finally:
        svc.kill()


def test_shutdown_answers_every_queued_request() -> None:
    svc = ServiceProcess().start()
    session = raw_session(svc.endpoint)
    try:
        with Client(session=session) as c:
            c.wait_ready()
            mover = _register(c)
            # batches long enough (up to about 1.5 s each, compiled engine or not) that most are still queued
            # when the signal comes: 12 m moves in the air (25 sub-steps each, under the step cap of 30),
            # as many as a probe batch says
            t0 = time.monotonic()
            assert all(r.ok is not None for r in session.get("acphys/lb/A9B4/move", payload=_batch(mover, 100, 12.0),
                                                            timeout=60.0))
            n = max(200, min(MAX_BATCH, int(100 * 1.5 / max(1e-3, time.monotonic() - t0))))
            base = c.get(mover)[0].seq
            moves_before = c.stats()[0]["requests"]["move"]
            col = Collector()
            for k in range(6):
                col.send(session, k, "acphys/lb/A9B4/move", _batch(mover, n, 12.0), timeout=120.0)
            # all six received (counted as they arrive, before they are decoded and queued)
            assert wait_until(lambda: c.stats()[0]["requests"]["move"] == moves_before + 6, timeout=30.0)
        signalled = time.monotonic()
        svc.proc.send_signal(signal.SIGTERM)  # type: ignore[union-attr]
        assert wait_until(lambda: len(col.finished) == 6, timeout=120.0)
        assert svc.proc.wait(60) == 0  # type: ignore[union-attr]
        outcome = []
        for k, replies in sorted(col.replies.items()):
            assert len(replies) == 1, (k, replies)  # exactly one answer each, none lost, none twice
            ok, msg = replies[0]
            if ok:
                assert len(msg["results"]) == n  # run in full, never cut short
                outcome.append(msg["results"][-1]["seq"])
            else:
                # one still being decoded when the signal came was never queued: it may be refused
                assert msg["error"]["kind"] == "shutting_down", msg
                outcome.append(None)
        done = [seq for seq in outcome if seq is not None]
        # the queued ones ran in the order sent; the refused ones (if any) were the last to arrive
        assert done == [base + n * (k + 1) for k in range(len(done))] and outcome[len(done):] == [None] * (6 - len(done))
        # and the shutdown did answer queued work: some results came after the signal
        assert any(col.answered_at[k] > signalled for k in range(len(done))), (signalled, col.answered_at)
    finally:
        session.close()
        svc.kill()


def test_a_request_run_in_the_callback_never_overtakes_a_queued_one() -> None:
    # batches too long to run in Zenoh's callback are queued; the single move sent right after them
    # would run in the callback if the engine were idle, but must wait for both (the mover's order)
    with ServiceProcess() as svc:
        session = raw_session(svc.endpoint)
        try:
            with Client(session=session) as c:
                c.wait_ready()
                mover = _register(c)
                col = Collector()
                seq = 0
                for r in range(3):
                    for k in range(2):
                        col.send(session, 3 * r + k, "acphys/lb/A9B4/move", _batch(mover, 600))
                    one = msgpack.packb({"v": 1, "move": {"id": mover, "offset": [0.001, 0.0, 0.0], "tag": r}})
                    col.send(session, 3 * r + 2, "acphys/lb/A9B4/move", one)
                    assert wait_until(lambda want=3 * r + 3: len(col.finished) == want, timeout=60.0)
                    for k in range(2):
                        [(ok, batch)] = col.replies[3 * r + k]
                        seq += 600
                        assert ok and batch["results"][-1]["seq"] == seq
                    [(ok, single)] = col.replies[3 * r + 2]
                    seq += 1
                    assert ok and single["state"]["seq"] == seq and single["state"]["tag"] == r
        finally:
            session.close()


def test_full_queue_pushes_back_and_answers_everyone() -> None:
    with ServiceProcess(extra=["--queue", "2"]) as svc:
        session = raw_session(svc.endpoint)
        try:
            with Client(session=session) as c:
                c.wait_ready()
                mover = _register(c)
                col = Collector()
                for n in range(20):
                    col.send(session, n, "acphys/lb/A9B4/move", _batch(mover, 300))
                assert wait_until(lambda: len(col.finished) == 20, timeout=60.0)
                kinds = []
                for replies in col.replies.values():
                    assert len(replies) == 1  # every request answered exactly once
                    ok, msg = replies[0]
                    kinds.append("ok" if ok else msg["error"]["kind"])
                assert "busy" in kinds and "ok" in kinds
                assert set(kinds) <= {"ok", "busy"}
                # the accepted batches all ran, nothing else did
                state, _ = c.get(mover)
                assert state.seq == 300 * kinds.count("ok")
                (stats,) = c.stats()
                assert stats["errors"]["busy"] == kinds.count("busy")
                assert c.health()[0]["status"] == "ok"
        finally:
            session.close()


def test_zenoh_config_file(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from support.service_harness import endpoint, free_port

    ep = endpoint(free_port())
    cfg = tmp_path / "zenoh.json5"
    cfg.write_text('{ mode: "peer", listen: { endpoints: ["%s"] }, scouting: { multicast: { enabled: false } } }' % ep)
    svc = ServiceProcess(extra=["--zenoh-config", str(cfg)])
    svc.args.remove("--listen")
    svc.args.remove(svc.endpoint)
    svc.endpoint = ep
    with svc:
        with Client([ep]) as c:
            c.wait_ready()
            assert c.move(_register(c), offset=(0.1, 0.0, 0.0)).ok
