"""The batch workload's benchmark: the bound beside the service sends and answers what the service would,
and the paired windows alternate fairly between the two."""

from __future__ import annotations

import msgpack
import numpy as np

from benchmarks.bench_batches import BATCH_STEP, _column_reply_size, _column_request_bytes, pair_ratios, window_targets
from engine.world.batch import BatchRows, append_missing
from service.column_moves import ColumnResults, reply_message
from service.protocol.column_request import parse_column_request
from support.sessions import SessionDouble


def test_the_bound_replies_with_as_many_bytes_as_the_service() -> None:
    for n in (1, 100, 300):  # bin lengths on both sides of msgpack's 255- and 65535-byte header steps
        rows = BatchRows()
        for _ in range(n):
            append_missing(rows)
        out = ColumnResults(n, rows)
        assert _column_reply_size(n) == len(reply_message(out)), n


def test_the_bound_is_sent_the_request_a_client_sends() -> None:
    ids = [5, 6, 7]
    req = parse_column_request(msgpack.unpackb(_column_request_bytes(ids)))
    assert req.kind == "offset" and req.n == 6 and not req.bad
    assert req.arrays["id"].tolist() == [5, 6, 7, 5, 6, 7]
    expected = np.array([[BATCH_STEP, 0, 0]] * 3 + [[-BATCH_STEP, 0, 0]] * 3)
    assert np.array_equal(req.arrays["offset"], expected)


class _CapturingSession(SessionDouble):
    """What Client uses of a zenoh.Session to send a batch: `get`, whose payload is kept; no reply comes."""

    def __init__(self) -> None:
        super().__init__()
        self.payloads: list[bytes] = []

    def get(self, key: object, payload: bytes, timeout: float) -> list[object]:
        self.payloads.append(payload)
        return []


def test_the_raw_clients_send_the_bytes_client_move_batch_sends() -> None:
    """The "columns, raw clients" form times the service on the request the client library would send."""
    from clients import Client

    ids = [0x10000001, 0x10000002, 0x10000003]
    session = _CapturingSession()
    client = Client(session=session)  # type: ignore[arg-type]
    for mid in ids:
        client.locate(mid, 0xA9B4)
    offsets = np.array([[BATCH_STEP, 0.0, 0.0]] * 3 + [[-BATCH_STEP, 0.0, 0.0]] * 3)
    results = client.move_batch(np.array(ids + ids, dtype=np.uint64), offsets=offsets)
    assert len(results.errors) == 6  # nobody answered: every item failed, and the request went out once
    assert session.payloads == [_column_request_bytes(ids)]


def test_each_pair_of_windows_holds_one_of_each_and_the_first_alternates() -> None:
    targets = window_targets(8)
    assert targets == ["service", "bare", "bare", "service", "service", "bare", "bare", "service"]
    assert window_targets(60).count("service") == 30


def test_a_pair_s_ratio_is_the_service_over_the_bound_whichever_came_first() -> None:
    targets = window_targets(4)  # service, bare | bare, service
    # the service's windows ran at 90 and 60, the bound's at 100 and 80: 90/100 and 60/80
    assert pair_ratios([90.0, 60.0], [100.0, 80.0], targets) == [0.9, 0.75]
