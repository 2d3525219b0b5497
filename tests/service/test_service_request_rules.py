"""One rule each, spoken by a raw client (zenoh and msgpack only, as tests/service/test_service_raw.py):

- keys: a request, put or query, must name its operation in the last chunk of its key
  (docs/protocol.md, "Key expressions"): a put on `P/lb/A9B4/*` or `P/lb/**` runs nothing and is
  answered on `P/errors`, as a query on such a key is refused;
- ids: id 0 is nobody's, so a move (map single, map batch, column, push), update, get or remove of
  id 0 is `unknown_mover`; a register with id 0 is `bad_value` (0 is reserved);
- names: a column the move column form does not know is refused (`bad_value`, path
  `columns.NAME`), as in the query column forms; a map form's unknown field is ignored.
"""

from __future__ import annotations

import re
import struct
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import msgpack
import pytest
import zenoh

from support.service_harness import ServiceProcess, raw_query, raw_session, wait_until

P = "acphys"
CELL = (0xA9B4 << 16) | (1 * 8 + 1 + 1)  # outdoor cell cx=1, cy=1 of A9B4: x 24..48, y 24..48
HUMAN = {"spheres": [{"center": [0.0, 0.0, 0.48], "radius": 0.48}], "state": ["IsPlayer"]}
MOVE_COLUMNS = ("dt", "id", "motion", "offset", "to_cell", "to_orientation", "to_origin", "velocity")


def pk(body: dict[str, Any]) -> bytes:
    return msgpack.packb(body)


class Errors:
    """What the service puts on `P/errors` and `P/obj/*/error`, as (key, message)."""

    def __init__(self, session: zenoh.Session) -> None:
        self.got: list[tuple[str, dict[str, Any]]] = []
        self._lock = threading.Lock()
        self._subs = [session.declare_subscriber(f"{P}/errors", self._on),
                      session.declare_subscriber(f"{P}/obj/*/error", self._on)]

    def _on(self, sample: zenoh.Sample) -> None:
        with self._lock:
            self.got.append((str(sample.key_expr), msgpack.unpackb(sample.payload.to_bytes(), raw=False)))

    def on(self, key: str) -> list[dict[str, Any]]:
        with self._lock:
            return [m for k, m in self.got if k == key]

    def close(self) -> None:
        for s in self._subs:
            s.undeclare()


@pytest.fixture(scope="module")
def session() -> Iterator[zenoh.Session]:
    with ServiceProcess() as svc:
        s = raw_session(svc.endpoint)
        assert wait_until(lambda: bool(list(s.get(f"{P}/health", timeout=1.0))), timeout=10.0)
        yield s
        s.close()


@pytest.fixture()
def errors(session: zenoh.Session) -> Iterator[Errors]:
    e = Errors(session)
    # a push that is always refused, until one is answered: the subscriptions are live
    for _ in range(50):
        session.put(f"{P}/lb/A9B4/push", b"\xc1")
        if wait_until(lambda: bool(e.on(f"{P}/errors")), timeout=0.2):
            break
    e.got.clear()
    yield e
    e.close()


def register(session: zenoh.Session, x: float) -> int:
    ok, reg = raw_query(session, f"{P}/lb/A9B4/register",
                        pk({"v": 1, "mover": HUMAN, "position": {"cell": CELL, "origin": [x, 30.0, 70.0]}}))
    assert ok, reg
    return int(reg["state"]["id"])


def seq_of(session: zenoh.Session, mover_id: int) -> int:
    ok, got = raw_query(session, f"{P}/lb/A9B4/get", pk({"v": 1, "id": mover_id}))
    assert ok, got
    return int(got["state"]["seq"])


def offset_columns(mover_id: int, **extra: bytes) -> dict[str, Any]:
    return {"v": 1, "kind": "offset",
            "columns": {"id": struct.pack("<Q", mover_id), "offset": struct.pack("<3d", 0.1, 0.0, 0.0), **extra}}


# -- keys -----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("key", [f"{P}/lb/A9B4/*", f"{P}/lb/**", f"{P}/**", f"{P}/lb/a9b4/push"])
def test_a_put_on_a_key_that_is_not_a_push_key_runs_nothing(session: zenoh.Session, errors: Errors, key: str) -> None:
    mover_id = register(session, 30.0)
    seq = seq_of(session, mover_id)
    session.put(key, pk({"v": 1, "move": {"id": mover_id, "offset": [0.5, 0.0, 0.0]}}),
                congestion_control=zenoh.CongestionControl.BLOCK)
    assert wait_until(lambda: bool(errors.on(f"{P}/errors")), timeout=10.0), errors.got
    (err,) = errors.on(f"{P}/errors")  # one instance, one subscriber: one answer
    assert err["v"] == 1 and err["key"] == key and err["error"]["kind"] == "bad_value"
    assert seq_of(session, mover_id) == seq  # the move did not run
    # the same move on the push key runs
    session.put(f"{P}/lb/A9B4/push", pk({"v": 1, "move": {"id": mover_id, "offset": [0.5, 0.0, 0.0]}}))
    assert wait_until(lambda: seq_of(session, mover_id) == seq + 1, timeout=10.0)
    assert errors.on(f"{P}/obj/{mover_id:X}/error") == []


def served_queryable_ops() -> set[str]:
    """The per-landblock operations docs/protocol.md's key table lists as queryables, but for those served in a
    cluster only: what a lone instance answers on `P/lb/XXYY/<op>` (read from the contract, not the code)."""
    text = (Path(__file__).resolve().parents[2] / "docs" / "protocol.md").read_text()
    rows = re.findall(r"^\| `P/lb/XXYY/(\w+)` \| queryable \| ([^|]*)\|", text, flags=re.M)
    return {op for op, served_by in rows if "cluster only" not in served_by}


def refusals(session: zenoh.Session, key: str, mover_id: int) -> list[str]:
    """The kinds of the replies to a `get`-shaped query on `key`, each of which must be an error."""
    replies = list(session.get(key, payload=pk({"v": 1, "id": mover_id}), timeout=5.0,
                               consolidation=zenoh.ConsolidationMode.NONE))
    errs = [r.err for r in replies if r.err is not None]
    assert len(errs) == len(replies), [r.ok for r in replies]
    return [msgpack.unpackb(e.payload.to_bytes())["error"]["kind"] for e in errs]


def stats_requests(session: zenoh.Session) -> dict[str, int]:
    ok, got = raw_query(session, f"{P}/stats", b"")
    assert ok, got
    return dict(got["requests"])


@pytest.mark.parametrize("key", [f"{P}/lb/A9B4/*", f"{P}/lb/**"])
def test_a_query_on_a_key_that_names_no_operation_is_refused_by_every_operation(session: zenoh.Session,
                                                                                 key: str) -> None:
    """Each operation's handler refuses it, as each of a queryable per operation did: one `bad_value` per
    operation, and each operation counts one request."""
    ops = served_queryable_ops()
    assert len(ops) == 13 and "move" in ops and "handover" not in ops  # the table read as meant
    mover_id = register(session, 31.0)
    before = stats_requests(session)
    assert refusals(session, key, mover_id) == ["bad_value"] * len(ops)
    after = stats_requests(session)
    for op in ops:
        assert after[op] - before[op] == 1, op
    assert after["push"] == before["push"]


def test_a_wildcard_within_the_last_chunk_reaches_the_operations_it_meets(session: zenoh.Session) -> None:
    mover_id = register(session, 31.5)
    assert refusals(session, f"{P}/lb/A9B4/mo$*", mover_id) == ["bad_value"]  # `move` alone
    ending_in_e = [op for op in served_queryable_ops() if op.endswith("e")]
    assert "move" in ending_in_e and "get" not in ending_in_e
    assert refusals(session, f"{P}/lb/A9B4/$*e", mover_id) == ["bad_value"] * len(ending_in_e)


@pytest.mark.parametrize("op", ["push", "handover", "nothing"])
def test_a_query_on_a_key_no_queryable_serves_gets_no_reply(session: zenoh.Session, op: str) -> None:
    """`push` is a subscriber's key and a lone instance takes no hand-over: Zenoh ends the query with no reply."""
    mover_id = register(session, 31.8)
    assert refusals(session, f"{P}/lb/A9B4/{op}", mover_id) == []
    ok, got = raw_query(session, f"{P}/lb/A9B4/get", pk({"v": 1, "id": mover_id}))  # still serving
    assert ok and got["state"]["id"] == mover_id


# -- ids ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("op", "body", "path"), [
    ("move", {"v": 1, "move": {"id": 0, "offset": [0.1, 0.0, 0.0]}}, "move.id"),
    ("get", {"v": 1, "id": 0}, "id"),
    ("remove", {"v": 1, "id": 0}, "id"),
    ("update", {"v": 1, "id": 0, "mover": HUMAN}, "id"),
])
def test_id_0_is_nobodys(session: zenoh.Session, op: str, body: dict[str, Any], path: str) -> None:
    ok, reply = raw_query(session, f"{P}/lb/A9B4/{op}", pk(body))
    assert not ok and reply["error"]["kind"] == "unknown_mover" and reply["error"]["path"] == path


def test_id_0_in_a_batch_fails_its_item_only(session: zenoh.Session) -> None:
    mover_id = register(session, 32.0)
    ok, reply = raw_query(session, f"{P}/lb/A9B4/move", pk({"v": 1, "moves": [
        {"id": 0, "offset": [0.1, 0.0, 0.0]}, {"id": mover_id, "offset": [0.1, 0.0, 0.0]}]}))
    assert ok, reply
    bad, good = reply["results"]
    assert bad["id"] == 0 and bad["error"]["kind"] == "unknown_mover" and bad["error"]["path"] == "moves[0].id"
    assert good["id"] == mover_id and "error" not in good


def test_id_0_in_a_column_request_fails_its_item_only(session: zenoh.Session) -> None:
    mover_id = register(session, 33.0)
    body = {"v": 1, "kind": "offset", "columns": {"id": struct.pack("<2Q", 0, mover_id),
                                                  "offset": struct.pack("<6d", 0.1, 0, 0, 0.1, 0, 0)}}
    ok, reply = raw_query(session, f"{P}/lb/A9B4/move", pk(body))
    assert ok, reply
    (err,) = reply["errors"]
    assert err["index"] == 0 and err["id"] == 0
    assert err["error"]["kind"] == "unknown_mover" and err["error"]["path"] == "columns.id[0]"
    assert struct.unpack("<2Q", reply["columns"]["seq"]) == (0, seq_of(session, mover_id))


def test_id_0_pushed_is_answered_on_its_error_key(session: zenoh.Session, errors: Errors) -> None:
    session.put(f"{P}/lb/A9B4/push", pk({"v": 1, "move": {"id": 0, "offset": [0.1, 0.0, 0.0], "tag": "zero"}}))
    assert wait_until(lambda: bool(errors.on(f"{P}/obj/0/error")), timeout=10.0), errors.got
    (err,) = errors.on(f"{P}/obj/0/error")
    assert err["id"] == 0 and err["tag"] == "zero" and err["error"]["kind"] == "unknown_mover"


def test_register_with_id_0_is_bad_value(session: zenoh.Session) -> None:
    ok, reply = raw_query(session, f"{P}/lb/A9B4/register",
                          pk({"v": 1, "id": 0, "mover": HUMAN, "position": {"cell": CELL, "origin": [34.0, 30.0, 70.0]}}))
    assert not ok and reply["error"]["kind"] == "bad_value" and reply["error"]["path"] == "id"
    ok, reply = raw_query(session, f"{P}/lb/A9B4/get", pk({"v": 1, "id": 0}))
    assert not ok and reply["error"]["kind"] == "unknown_mover"  # nothing was registered


# -- names the vocabulary does not know -----------------------------------------------------------------
def test_an_unknown_column_refuses_the_whole_request(session: zenoh.Session) -> None:
    mover_id = register(session, 35.0)
    seq = seq_of(session, mover_id)
    typo = offset_columns(mover_id, velocty=struct.pack("<3d", 1.0, 0.0, 0.0))
    ok, reply = raw_query(session, f"{P}/lb/A9B4/move", pk(typo))
    assert not ok
    err = reply["error"]
    assert err["kind"] == "bad_value" and err["path"] == "columns.velocty"
    assert "velocty" in err["message"] and all(name in err["message"] for name in MOVE_COLUMNS)
    assert seq_of(session, mover_id) == seq  # nothing ran
    ok, reply = raw_query(session, f"{P}/lb/A9B4/move", pk(offset_columns(mover_id)))
    assert ok and reply["errors"] == []


def test_an_unknown_column_pushed_is_answered_on_p_errors(session: zenoh.Session, errors: Errors) -> None:
    mover_id = register(session, 36.0)
    seq = seq_of(session, mover_id)
    session.put(f"{P}/lb/A9B4/push", pk(offset_columns(mover_id, velocty=struct.pack("<3d", 1.0, 0.0, 0.0))))
    assert wait_until(lambda: bool(errors.on(f"{P}/errors")), timeout=10.0), errors.got
    (err,) = errors.on(f"{P}/errors")
    assert err["error"]["kind"] == "bad_value" and err["error"]["path"] == "columns.velocty"
    assert seq_of(session, mover_id) == seq


def test_a_map_forms_unknown_fields_are_ignored(session: zenoh.Session) -> None:
    mover_id = register(session, 37.0)
    seq = seq_of(session, mover_id)
    ok, reply = raw_query(session, f"{P}/lb/A9B4/move", pk({"v": 1, "later_field": 1, "move": {
        "id": mover_id, "offset": [0.1, 0.0, 0.0], "velocty": [1.0, 0.0, 0.0]}}))
    assert ok, reply
    assert reply["state"]["seq"] == seq + 1
    ok, reply = raw_query(session, f"{P}/lb/A9B4/get", pk({"v": 1, "id": mover_id, "later_field": [1, 2]}))
    assert ok and reply["state"]["seq"] == seq + 1
