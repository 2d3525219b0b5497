"""Faults in scale-out: one of two instances is killed (SIGKILL) during cross-border traffic.

The survivor keeps serving its movers; requests for the dead one's get errors (the client's timeouts),
not hangs; no mover is ever held by two instances; restarted with its `--state`, the dead instance
has its movers back.
"""

from __future__ import annotations

import threading
import time
from pathlib import Path

import msgpack
import pytest
import zenoh

from clients import Client
from clients.demo.world import global_to_cell
from clients.errors import AcphysError
from support.cluster_files import cluster_file, make_certificates, tls_endpoint
from service.persistence.journal import DEFAULT_BUDGET
from support.service_harness import ServiceProcess, demo_world, human, raw_session, start_on_ground


def holders(session: zenoh.Session, mover_id: int) -> int:
    """How many instances answer a `get` of the mover with its state (an instance owning two landblocks
    answers on each of its two keys: counted once, by its Zenoh id)."""
    replies = session.get("acphys/lb/*/get", payload=msgpack.packb({"v": 1, "id": mover_id}),
                          target=zenoh.QueryTarget.ALL, consolidation=zenoh.ConsolidationMode.NONE, timeout=3.0)
    return len({str(r.replier_id.zid) for r in replies if r.ok is not None})


def test_kill_one_instance_during_cross_border_traffic(tmp_path: Path) -> None:
    make_certificates(tmp_path)
    a_tls, b_tls = tls_endpoint(), tls_endpoint()
    a_args = ["--cluster", str(cluster_file(tmp_path, "a", [a_tls], [])), "--state", str(tmp_path / "a.state"),
              "--state-interval", "0.3"]
    b_args = ["--cluster", str(cluster_file(tmp_path, "b", [b_tls], [a_tls])), "--state", str(tmp_path / "b.state"),
              "--state-interval", "0.3"]
    world = demo_world()

    def on_ground(gx: float, gy: float):  # type: ignore[no-untyped-def]
        cell, x, y = global_to_cell(gx, gy)
        return start_on_ground(world, cell, x, y)

    with ServiceProcess(own="A9B4,A9B5", extra=a_args) as a:
        b = ServiceProcess(own="AAB4,AAB5", extra=b_args).start()
        session = raw_session(a.endpoint)
        try:
            with Client(session=session, timeout=3.0) as c:
                c.wait_ready(instances=2)
                west = c.register(human(), on_ground(100.0, 100.0))  # A's
                east = c.register(human(), on_ground(260.0, 100.0))  # B's
                crosser = c.register(human(), on_ground(188.0, 60.0))
                for _ in range(5):
                    east = c.step(east.id, (0.0, 0.0, 0.0), 0.2)
                    crosser = c.step(crosser.id, (0.0, 0.0, 0.0), 0.2)
                while crosser.landblock == 0xA9B4:  # into B's landblock: handed over
                    crosser = c.move(crosser.id, offset=(1.0, 0.0, 0.0), velocity=(0.0, 0.0, 0.0))
                time.sleep(1.0)  # B's interval save has them all

                stop = threading.Event()
                traffic_errors: list[str] = []

                crossings: list[int] = []

                def traffic() -> None:  # three steps west, three east: over the border and back, until told
                    for k in range(2000):
                        if stop.is_set():
                            return
                        dx = -1.0 if (k // 3) % 2 == 0 else 1.0
                        try:
                            st = c.move(crosser.id, offset=(dx, 0.0, 0.0), velocity=(0.0, 0.0, 0.0))
                            crossings.append(st.landblock)
                        except AcphysError as e:
                            traffic_errors.append(type(e).__name__)

                runner = threading.Thread(target=traffic, daemon=True)
                runner.start()
                time.sleep(1.5)
                assert {0xA9B4, 0xAAB4} <= set(crossings)  # the mover is going back and forth
                b.kill()  # SIGKILL, mid-traffic
                time.sleep(1.0)
                stop.set()
                runner.join(30.0)
                assert not runner.is_alive()

                # the survivor serves its own movers
                for _ in range(5):
                    assert c.move(west.id, offset=(0.2, 0.0, 0.0)).ok
                # the dead instance's movers: an error within the client's timeout, not a hang
                with pytest.raises(AcphysError):
                    c.move(east.id, offset=(0.2, 0.0, 0.0))
                assert holders(session, west.id) == 1 and holders(session, east.id) == 0

                # restarted with its state file: its movers are back, none held twice
                b = ServiceProcess(own="AAB4,AAB5", extra=b_args).start()
                c.wait_ready(instances=2, timeout=20.0)
                back, _ = c.get(east.id)
                # killed: its seqs go on above any it may have answered after its log's last sync
                assert back.seq == east.seq + DEFAULT_BUDGET + 1 and back.landblock == 0xAAB4
                for mover_id in (west.id, east.id, crosser.id):
                    assert holders(session, mover_id) == 1, hex(mover_id)
                found = c.find(crosser.id)
                assert c.move(crosser.id, offset=(0.1, 0.0, 0.0)).seq == found.seq + 1
        finally:
            session.close()
            b.kill()
