"""Shutdown answers everything: a SIGTERM in the middle of a flood of move queries leaves no query
without its reply, and none with two (docs/protocol.md, "Ordering, back-pressure and shutdown")."""

from __future__ import annotations

import signal
import threading
from collections import Counter
from typing import Any

import msgpack
import zenoh

from clients import Client
from clients.demo.world import global_to_cell
from engine.geometry import Position, Vec3
from support.service_harness import ServiceProcess, human, raw_session, wait_until


def test_sigterm_during_a_flood_answers_every_query_exactly_once() -> None:
    sent = 3000
    svc = ServiceProcess().start()
    session = raw_session(svc.endpoint)
    try:
        with Client(session=session) as c:
            c.wait_ready()
            cell, x, y = global_to_cell(40.0, 40.0)
            mover = c.register(human(), Position.at(cell, Vec3(x, y, 60.0))).id
        replies: dict[int, list[tuple[bool, Any]]] = {n: [] for n in range(sent)}
        finished: set[int] = set()
        lock = threading.Lock()

        def handlers(n: int) -> zenoh.handlers.Callback:
            def on_reply(r: zenoh.Reply) -> None:
                raw = (r.ok or r.err).payload.to_bytes()
                try:
                    msg = msgpack.unpackb(raw, raw=False)
                except Exception:  # Zenoh's own "Timeout" text: the service never answered
                    msg = {"error": {"kind": "transport", "message": raw.decode("utf-8", "replace")}}
                with lock:
                    replies[n].append((r.ok is not None, msg))

            def on_done() -> None:
                with lock:
                    finished.add(n)

            return zenoh.handlers.Callback(on_reply, on_done)

        payload = msgpack.packb({"v": 1, "move": {"id": mover, "offset": [0.001, 0.0, 0.0]}})
        for n in range(sent):
            if n == sent // 4:  # the first quarter is on its way or queued; the rest follows the signal
                svc.proc.send_signal(signal.SIGTERM)  # type: ignore[union-attr]
            session.get("acphys/lb/A9B4/move", handlers(n), payload=payload, timeout=60.0)
        assert wait_until(lambda: len(finished) == sent, timeout=90.0)
        assert svc.proc.wait(30) == 0  # type: ignore[union-attr]
        counts = Counter(len(r) for r in replies.values())
        assert counts == Counter({1: sent}), counts  # every query answered, none twice
        kinds = Counter("ok" if ok else msg["error"]["kind"] for [(ok, msg)] in replies.values())
        assert set(kinds) <= {"ok", "shutting_down"}, kinds
        assert kinds["shutting_down"] > 0  # the signal did land in the middle of the flood
        # the moves that ran are each counted once, without gaps: seq 1..k
        seqs = sorted(msg["state"]["seq"] for [(ok, msg)] in replies.values() if ok)
        assert seqs == list(range(1, kinds["ok"] + 1))
    finally:
        session.close()
        svc.kill()
