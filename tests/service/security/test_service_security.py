"""Instance keys are closed to clients by Zenoh's own TLS and access control (service/security/cluster.py).

A plain client (tcp, no credentials) keeps every ordinary operation but cannot put a mover into an
instance by a forged hand-over, nor answer hand-overs in an instance's place; two instances joined
by the cluster's mutual TLS still hand movers over. A single instance with default settings takes
no hand-over at all.
"""

from __future__ import annotations

import json
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import msgpack
import pytest
import zenoh

from clients import Client, ServiceError
from clients.demo.world import global_to_cell
from support.cluster_files import cluster_file, cluster_pair, make_certificates, tls_endpoint
from engine.geometry import Position, Vec3
from service.protocol.codec import encode_mover_spec, encode_position
from support.service_harness import ServiceProcess, demo_world, human, raw_session, start_on_ground, wait_until


def _forged(mover_id: int, lb_x: float, seq: int = 1000) -> bytes:
    """A well-formed hand-over (as an instance would send it) of a mover standing at global (lb_x, 100)."""
    cell, x, y = global_to_cell(lb_x, 100.0)
    return msgpack.packb({"v": 1, "id": mover_id, "seq": seq, "from": "forger",
                          "mover": encode_mover_spec(human()),
                          "position": encode_position(Position.at(cell, Vec3(x, y, 80.0)))})


def _answers(session: zenoh.Session, key: str, payload: bytes) -> list[tuple[bool, Any]]:
    out = []
    for r in session.get(key, payload=payload, timeout=3.0):
        raw = (r.ok or r.err).payload.to_bytes()
        try:
            out.append((r.ok is not None, msgpack.unpackb(raw, raw=False)))
        except Exception:
            out.append((False, raw.decode("utf-8", "replace")))
    return out


def _handovers_in(c: Client) -> int:
    return sum(s["handovers"]["in"] for s in c.stats())


def test_a_default_instance_takes_no_handover() -> None:
    with ServiceProcess() as svc:
        session = raw_session(svc.endpoint)
        try:
            with Client(session=session) as c:
                c.wait_ready()
                # nobody serves the key: the query ends with no reply at all
                assert _answers(session, "acphys/lb/A9B4/handover", _forged(0x77, 20.0)) == []
                # a wildcard reaches the other operations' queryables, which refuse a key not naming them
                answers = _answers(session, "acphys/lb/A9B4/*", _forged(0x77, 20.0))
                assert answers and all(not ok and a["error"]["kind"] == "bad_value" for ok, a in answers), answers
                with pytest.raises(ServiceError) as e:
                    c.get(0x77)
                assert e.value.kind == "unknown_mover"
                (stats,) = c.stats()
                assert stats["handovers"]["in"] == 0 and stats["requests"]["handover"] == 0
        finally:
            session.close()


@pytest.fixture(scope="module")
def cluster(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[ServiceProcess, ServiceProcess]]:
    a_args, b_args = cluster_pair(tmp_path_factory.mktemp("cluster"))
    with ServiceProcess(own="A9B4,A9B5", extra=a_args) as a:
        with ServiceProcess(own="AAB4,AAB5", extra=b_args) as b:
            yield a, b


def test_plain_client_cannot_forge_a_handover_but_still_moves(cluster: tuple[ServiceProcess, ServiceProcess]) -> None:
    a, _ = cluster
    session = raw_session(a.endpoint)  # plain tcp, no credentials
    try:
        with Client(session=session, timeout=10.0) as c:
            c.wait_ready(instances=2)
            world = demo_world()
            cell, x, y = global_to_cell(150.0, 100.0)
            mine = c.register(human(), start_on_ground(world, cell, x, y))
            before = _handovers_in(c)
            # a new id into each instance, and the client's own mover with a jump in seq, on the literal keys
            for lb, gx in (("A9B4", 20.0), ("AAB4", 200.0)):
                for mover_id in (0x51, mine.id):
                    answers = _answers(session, f"acphys/lb/{lb}/handover", _forged(mover_id, gx))
                    # Zenoh drops the query at the instance (access control): no reply; never an acceptance
                    assert all(not ok for ok, _ in answers), answers
                    assert _answers(session, f"acphys/lb/{lb}/*", _forged(mover_id, gx)) and \
                        all(not ok for ok, _ in _answers(session, f"acphys/lb/{lb}/*", _forged(mover_id, gx)))
            with pytest.raises(ServiceError) as e:
                c.find(0x51, timeout=3.0)
            assert e.value.kind in ("unknown_mover", "no_service")
            assert c.get(mine.id)[0].seq == 0  # its seq was not taken from the forgery
            assert _handovers_in(c) == before
            # the same client's ordinary requests work
            st = c.move(mine.id, offset=(0.5, 0.0, 0.0))
            assert st.ok and st.seq == 1
            c.remove(mine.id)
    finally:
        session.close()


def test_plain_client_cannot_answer_handovers_and_instances_still_hand_over(
        cluster: tuple[ServiceProcess, ServiceProcess]) -> None:
    a, _ = cluster
    session = raw_session(a.endpoint)
    stolen: list[str] = []
    lock = threading.Lock()

    def thief(q: zenoh.Query) -> None:
        with lock:
            stolen.append(str(q.key_expr))
        q.reply(q.key_expr, msgpack.packb({"v": 1, "id": 0, "accepted": True}))

    try:
        # declared from a plain link: Zenoh refuses the declaration, so no hand-over is routed here
        q = session.declare_queryable("acphys/lb/AAB4/handover", thief)
        with Client(session=session, timeout=10.0) as c:
            c.wait_ready(instances=2)
            world = demo_world()
            cell, x, y = global_to_cell(185.0, 100.0)
            st = c.register(human(), start_on_ground(world, cell, x, y))
            for _ in range(5):
                st = c.step(st.id, (0.0, 0.0, 0.0), 0.2)
            before = _handovers_in(c)
            for _ in range(15):  # walks east over x = 192 into AAB4, owned by B
                st = c.move(st.id, offset=(1.0, 0.0, 0.0), velocity=(0.0, 0.0, 0.0))
            assert st.landblock == 0xAAB4
            assert _handovers_in(c) == before + 1  # B took it, over the instances' TLS link
            found = c.find(st.id)
            assert found.seq == st.seq and found.landblock == 0xAAB4
            c.remove(st.id)
        q.undeclare()
        assert stolen == []
    finally:
        session.close()


def test_a_tls_session_without_the_clusters_certificate_gets_nothing(tmp_path: Path) -> None:
    # another CA's certificate: the instance's mutual TLS refuses the link, so no hand-over can come that way
    ours = make_certificates(tmp_path / "ours")
    theirs = make_certificates(tmp_path / "theirs")
    listen = tls_endpoint()
    with ServiceProcess(own="A9B4", extra=["--cluster", str(cluster_file(ours, "a", [listen], []))]):
        cfg = zenoh.Config()
        cfg.insert_json5("mode", '"peer"')
        cfg.insert_json5("scouting/multicast/enabled", "false")
        cfg.insert_json5("connect/endpoints", f'["{listen}"]')
        cfg.insert_json5("transport/link/tls", '{"root_ca_certificate": "%s", "connect_certificate": "%s", '
                         '"connect_private_key": "%s", "verify_name_on_connect": false}'
                         % (ours / "ca.pem", theirs / "acphys-instance.pem", theirs / "acphys-instance-key.pem"))
        try:
            s = zenoh.open(cfg)
        except zenoh.ZError:
            return  # refused at connect: nothing reached the instance
        try:
            assert _answers(s, "acphys/lb/A9B4/handover", _forged(0x99, 20.0)) == []
            assert not wait_until(lambda: bool(list(s.get("acphys/health", timeout=1.0))), timeout=2.0)
        finally:
            s.close()


def test_access_control_of_a_config_file_is_kept_and_ours_added(tmp_path: Path) -> None:
    # an operator's own rule (here: nobody may query P/stats) stays beside the service's
    from support.service_harness import endpoint, free_port

    ep = endpoint(free_port())
    cfg = tmp_path / "zenoh.json5"
    cfg.write_text("""{ mode: "peer", listen: { endpoints: ["%s"] }, scouting: { multicast: { enabled: false } },
      access_control: { enabled: true, default_permission: "allow",
        rules: [{ id: "no-stats", permission: "deny", flows: ["ingress"], messages: ["query"],
                  key_exprs: ["acphys/stats"] }],
        subjects: [{ id: "everyone-tcp", link_protocols: ["tcp"] }],
        policies: [{ id: "ops", rules: ["no-stats"], subjects: ["everyone-tcp"] }] } }""" % ep)
    svc = ServiceProcess(extra=["--zenoh-config", str(cfg)])
    svc.args.remove("--listen")
    svc.args.remove(svc.endpoint)
    svc.endpoint = ep
    with svc:
        s = raw_session(ep)
        try:
            assert wait_until(lambda: bool(list(s.get("acphys/health", timeout=1.0))), timeout=10.0)
            assert list(s.get("acphys/stats", timeout=1.0)) == []  # theirs
            with Client(session=s) as c:  # everything else as usual
                cell, x, y = global_to_cell(40.0, 40.0)
                st = c.register(human(), Position.at(cell, Vec3(x, y, 60.0)))
                assert c.move(st.id, offset=(0.1, 0.0, 0.0)).seq == 1
        finally:
            s.close()


def test_the_services_rules_are_added_to_a_config_files_own() -> None:
    from service.security.cluster import apply_security

    cfg = zenoh.Config()
    cfg.insert_json5("access_control", """{ enabled: true, default_permission: "allow",
        rules: [{ id: "no-stats", permission: "deny", flows: ["ingress"], messages: ["query"],
                  key_exprs: ["acphys/stats"] }],
        subjects: [{ id: "everyone-tcp", link_protocols: ["tcp"] }],
        policies: [{ id: "ops", rules: ["no-stats"], subjects: ["everyone-tcp"] }] }""")
    apply_security(cfg, "acphys", None)
    acl = json.loads(cfg.get_json("access_control"))
    rules = {r["id"]: r for r in acl["rules"]}
    assert "no-stats" in rules  # theirs
    assert rules["instance-queries"]["key_exprs"] == ["acphys/lb/*/handover"]  # ours
    assert rules["instance-queries"]["permission"] == "deny" and rules["instance-queries"]["flows"] == ["ingress"]
    assert {p["id"] for p in acl["policies"]} == {"ops", "clients"}
    plain = next(sub for sub in acl["subjects"] if sub["id"] == "plain-links")
    assert "tcp" in plain["link_protocols"] and "tls" not in plain["link_protocols"]
    cfg.insert_json5("listen/endpoints", '["tcp/127.0.0.1:0"]')  # loopback only, nothing scouted
    cfg.insert_json5("scouting/multicast/enabled", "false")
    zenoh.open(cfg).close()  # and Zenoh takes the merged block


def test_a_workers_router_refuses_a_plain_clients_handover_and_still_hands_over_between_its_workers() -> None:
    """`serve --workers 2`: the workers reach the router over mutual TLS (a throwaway CA of the parent's),
    clients over plain tcp; the router's access control drops a client's forged hand-over where it enters,
    while a mover walking across the split is handed from worker to worker."""
    with ServiceProcess(extra=["--workers", "2"]) as svc:
        session = raw_session(svc.endpoint)
        try:
            with Client(session=session, timeout=10.0) as c:
                c.wait_ready()
                world = demo_world()
                cell, x, y = global_to_cell(170.0, 100.0)  # west of the split (A9B4 | AAB4 at global x 192)
                mine = c.register(human(), start_on_ground(world, cell, x, y))
                before = _handovers_in(c)
                for lb, gx in (("A9B4", 20.0), ("AAB4", 200.0)):
                    answers = _answers(session, f"acphys/lb/{lb}/handover", _forged(0x52, gx))
                    assert answers == [], answers  # dropped by the router: no worker ever saw it
                with pytest.raises(ServiceError) as e:
                    c.find(0x52, timeout=3.0)
                assert e.value.kind in ("unknown_mover", "no_service")
                assert _handovers_in(c) == before
                st = mine
                for _ in range(30):  # east across the border: one hand-over between the workers
                    st = c.move(mine.id, offset=(1.0, 0.0, 0.0))
                assert st.landblock == 0xAAB4 and st.seq == 30
                assert _handovers_in(c) == before + 1
        finally:
            session.close()
