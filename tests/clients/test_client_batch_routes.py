"""Client.move_batch's routing and reassembly, against a stand-in for the service's replies.

The stand-in answers each column request from tables written out here by hand (no engine, no bus), so
that every path of clients/batch.py is driven on purpose: one landblock answering the whole batch, a
batch split over two landblocks, and a `moved` redirect after which the item is sent again to the
landblock the error names.
"""

from __future__ import annotations

from typing import Any

import msgpack
import numpy as np
import pytest

from clients.batch import move_batch
from service.protocol.columns import REPLY_BY_NAME, REPLY_COLUMNS, REQUEST_BY_NAME, Flag, pack_columns, unpack_column
from service.protocol.wire import Keys
from support.sessions import SessionDouble

RESOLVED = Flag.RESOLVED | Flag.OK


class StandInClient:
    """What move_batch uses of a Client (clients/request_channel.py's RequestChannel): `known_landblocks`, `keys`,
    `landblock_of`, `send_request` and `receive_reply`."""

    def __init__(self, where: dict[int, int], holder: dict[int, int], collide: dict[int, list[int]]) -> None:
        self.known_landblocks = dict(where)
        self.keys = Keys("t")
        self.holder = holder  # mover id -> the landblock that really holds it
        self.collide = collide  # mover id -> ids it collides with on every move
        self.sent: list[tuple[int, list[int]]] = []  # (landblock, ids) of every request
        self.log: list[str] = []  # "send XX" and "receive XX", in the order they happened

    def landblock_of(self, mover_id: int) -> int:
        return self.known_landblocks[mover_id]

    def receive_reply(self, pending: tuple[int, dict[str, Any]]) -> dict[str, Any]:
        lb, reply = pending
        self.log.append(f"receive {lb:X}")
        return reply

    def send_request(self, key: str, body: dict[str, Any], timeout: float | None) -> tuple[int, dict[str, Any]]:
        """The reply, worked out when the request is sent (as the service starts on it then)."""
        lb = int(key.split("/")[2], 16)
        self.log.append(f"send {lb:X}")
        raw = body["columns"]
        n = len(raw["id"]) // 8
        ids = unpack_column(REQUEST_BY_NAME["id"], raw["id"], n).tolist()
        offsets = unpack_column(REQUEST_BY_NAME["offset"], raw["offset"], n)
        self.sent.append((lb, ids))
        cols: dict[str, Any] = {c.name: np.zeros((n,) if c.width == 1 else (n, c.width)) for c in REPLY_COLUMNS}
        for name in ("origin", "orientation", "contact_plane", "collision_normal", "sliding_normal"):
            cols[name][:] = np.nan
        errors, collide_ids = [], []
        for j, mid in enumerate(ids):
            if self.holder[mid] != lb:
                errors.append({"index": j, "id": mid, "error": {"kind": "moved", "message": "handed over",
                                                                "landblock": self.holder[mid]}})
                continue
            # the result: the mover's id as its seq, its offset's x as origin x, its landblock in the cell
            cols["seq"][j] = mid
            cols["cell"][j] = (lb << 16) | 1
            cols["origin"][j] = (offsets[j][0], 0.0, 0.0)
            cols["flags"][j] = RESOLVED
            cols["collide_count"][j] = len(self.collide.get(mid, []))
            collide_ids += self.collide.get(mid, [])
        packed = pack_columns(REPLY_COLUMNS, cols)
        packed["collide_ids"] = np.array(collide_ids, dtype="<u8").tobytes()
        return lb, {"v": 1, "n": n, "columns": packed, "errors": errors}


def test_one_landblock_answers_the_whole_batch_and_results_are_writable() -> None:
    c = StandInClient({1: 0x10, 2: 0x10}, {1: 0x10, 2: 0x10}, {2: [1]})
    r = move_batch(c, [1, 2, 1], offsets=[[1.0, 0, 0], [2.0, 0, 0], [3.0, 0, 0]])
    assert c.sent == [(0x10, [1, 2, 1])]
    assert r.errors == {}
    assert r.seq.tolist() == [1, 2, 1]
    assert r.origin[:, 0].tolist() == [1.0, 2.0, 3.0]
    assert r.collide_objects(1) == [1] and r.collide_objects(0) == [] and r.collide_objects(2) == []
    r.origin += 1.0  # the caller's arrays, not views of the reply's read-only bytes
    assert r.origin[:, 0].tolist() == [2.0, 3.0, 4.0]


def test_two_landblocks_are_asked_apart_and_put_back_in_order() -> None:
    c = StandInClient({1: 0x10, 2: 0x20, 3: 0x10}, {1: 0x10, 2: 0x20, 3: 0x10}, {3: [7, 8], 2: [9]})
    r = move_batch(c, [2, 1, 3], offsets=[[1.0, 0, 0], [2.0, 0, 0], [3.0, 0, 0]])
    assert sorted(c.sent) == [(0x10, [1, 3]), (0x20, [2])]
    # both requests go out before either reply is read: the two landblocks' instances work at once
    assert c.log == ["send 20", "send 10", "receive 20", "receive 10"]
    assert r.seq.tolist() == [2, 1, 3]
    assert r.landblock.tolist() == [0x20, 0x10, 0x10]
    assert r.origin[:, 0].tolist() == [1.0, 2.0, 3.0]
    assert r.collide_ids.tolist() == [9, 7, 8]  # item after item, whichever reply came first
    assert r.collide_objects(0) == [9] and r.collide_objects(2) == [7, 8]


def test_a_moved_item_is_sent_again_where_the_error_says() -> None:
    # the client still thinks mover 2 is in 0x10; the service has handed it to 0x20
    c = StandInClient({1: 0x10, 2: 0x10}, {1: 0x10, 2: 0x20}, {1: [5], 2: [6]})
    r = move_batch(c, [1, 2], offsets=[[1.0, 0, 0], [2.0, 0, 0]])
    assert c.sent == [(0x10, [1, 2]), (0x20, [2])]
    assert r.errors == {}
    assert r.seq.tolist() == [1, 2]
    assert r.origin[:, 0].tolist() == [1.0, 2.0]
    assert (r.flags & Flag.RESOLVED).tolist() == [Flag.RESOLVED, Flag.RESOLVED]
    assert r.collide_ids.tolist() == [5, 6]
    assert c.known_landblocks == {1: 0x10, 2: 0x20}


def test_a_mover_that_keeps_moving_away_ends_as_its_error() -> None:
    class Restless(StandInClient):
        def send_request(self, key: str, body: dict[str, Any], timeout: float | None) -> tuple[int, dict[str, Any]]:
            self.holder[2] += 1  # handed on before each request arrives
            return super().send_request(key, body, timeout)

    c = Restless({1: 0x10, 2: 0x10}, {1: 0x10, 2: 0x10}, {})
    r = move_batch(c, [1, 2], offsets=[[1.0, 0, 0], [2.0, 0, 0]])
    assert set(r.errors) == {1} and r.errors[1].kind == "moved"
    assert r.seq.tolist() == [1, 0] and np.isnan(r.origin[1]).all()
    assert int(r.flags[1]) == 0


def test_a_move_that_ends_in_another_landblock_is_remembered_there() -> None:
    class Crossing(StandInClient):
        """Mover 2's move ends in landblock 0x11, which the instance serving 0x10 also holds."""

        def send_request(self, key: str, body: dict[str, Any], timeout: float | None) -> tuple[int, dict[str, Any]]:
            lb, reply = super().send_request(key, body, timeout)
            cols = reply["columns"]
            cells = unpack_column(REPLY_BY_NAME["cell"], cols["cell"], reply["n"]).copy()
            ids = unpack_column(REQUEST_BY_NAME["id"], body["columns"]["id"], reply["n"]).tolist()
            cells[[j for j, mid in enumerate(ids) if mid == 2]] = (0x11 << 16) | 1
            cols["cell"] = cells.astype("<u4").tobytes()
            return lb, reply

    c = Crossing({1: 0x10, 2: 0x10, 3: 0x10}, {1: 0x10, 2: 0x10, 3: 0x10}, {})
    r = move_batch(c, [1, 2, 3], offsets=[[1.0, 0, 0], [2.0, 0, 0], [3.0, 0, 0]])
    assert r.landblock.tolist() == [0x10, 0x11, 0x10]
    assert c.known_landblocks == {1: 0x10, 2: 0x11, 3: 0x10}
    # the next batch goes to where each mover is now
    c.holder[2] = 0x11
    move_batch(c, [1, 2], offsets=[[1.0, 0, 0], [2.0, 0, 0]])
    assert sorted(c.sent[1:]) == [(0x10, [1]), (0x11, [2])]


@pytest.mark.parametrize("shape", [(2, 2), (3, 3)])
def test_wrong_shapes_are_refused_before_anything_is_sent(shape: tuple[int, int]) -> None:
    c = StandInClient({1: 0x10, 2: 0x10}, {1: 0x10, 2: 0x10}, {})
    with pytest.raises(ValueError, match="offset"):
        move_batch(c, [1, 2], offsets=np.zeros(shape))
    assert c.sent == []


class _LoggedReplies:
    """Zenoh's receiver of one query's replies: logs when it is read."""

    def __init__(self, log: list[str], lb: int, payload: bytes) -> None:
        self.log, self.lb, self.payload = log, lb, payload

    def __iter__(self) -> Any:
        self.log.append(f"receive {self.lb:X}")
        reply = type("Reply", (), {})()
        reply.ok = type("Sample", (), {"payload": type("Payload", (), {"to_bytes": lambda _s, p=self.payload: p})()})()
        reply.err = None
        return iter([reply])


class _LoggedSession(SessionDouble):
    """What Client uses of a zenoh.Session for a map batch: `get`, answered with every move resolved (its
    id as seq) by the landblock the key names."""

    def __init__(self) -> None:
        super().__init__()
        self.log: list[str] = []

    def get(self, key: Any, payload: bytes, timeout: float) -> _LoggedReplies:
        lb = int(str(key).split("/")[2], 16)
        self.log.append(f"send {lb:X}")
        moves = msgpack.unpackb(payload)["moves"]
        results = [{"id": m["id"], "landblock": lb, "seq": m["id"]} for m in moves]
        return _LoggedReplies(self.log, lb, msgpack.packb({"v": 1, "results": results}))


def test_a_map_batch_sends_every_landblocks_request_before_reading_a_reply() -> None:
    from clients import Client, Move

    session = _LoggedSession()
    client = Client(session=session)  # type: ignore[arg-type]
    for mid, lb in ((1, 0x10), (2, 0x20), (3, 0x10)):
        client.locate(mid, lb)
    entries = client.move_many_maps([Move(m, offset=(1.0, 0.0, 0.0)) for m in (2, 1, 3)])
    assert session.log == ["send 20", "send 10", "receive 20", "receive 10"]
    assert [(e["id"], e["landblock"]) for e in entries] == [(2, 0x20), (1, 0x10), (3, 0x10)]  # type: ignore[index]
