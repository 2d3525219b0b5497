"""A column request's checks (service/protocol/column_request.py): the quick test over all columns at once
agrees with the column-by-column checks on what is refused and how, and the quick test over a real column's
values lets nothing through that is NaN, infinite or beyond float32's range."""

from __future__ import annotations

import math
import random
import struct
from typing import Any

import numpy as np
import pytest

from service.protocol.column_request import _columns_one_by_one, parse_column_request
from service.protocol.columns import FLOAT32_MAX, REQUEST_COLUMNS
from service.protocol.errors import ProtocolError

_KINDS = ("offset", "to", "motion")
_ITEM_BYTES = {c.name: c.item_bytes for c in REQUEST_COLUMNS}


def _column(name: str, n: int, rng: random.Random) -> bytes:
    col = next(c for c in REQUEST_COLUMNS if c.name == name)
    if name == "dt":
        return struct.pack(f"<{n}d", *([0.05] * n))
    if name == "to_orientation":
        return struct.pack(f"<{4 * n}d", *([1.0, 0.0, 0.0, 0.0] * n))
    if col.real:
        return struct.pack(f"<{col.width * n}d", *(rng.uniform(-50.0, 50.0) for _ in range(col.width * n)))
    return struct.pack(f"<{n}{'Q' if col.dtype == 'u64' else 'I'}", *(rng.randrange(1, 1 << 32) for _ in range(n)))


def _request(kind: str, n: int, rng: random.Random) -> dict[str, Any]:
    cols = {c.name: _column(c.name, n, rng) for c in REQUEST_COLUMNS
            if kind in c.required or (kind in c.optional and rng.random() < 0.5)}
    return {"v": 1, "kind": kind, "columns": cols}


def _spoilt(msg: dict[str, Any], rng: random.Random) -> dict[str, Any]:
    """`msg` with one or two of its columns made wrong (missing, nil, not binary, not whole items, one
    item more), or given anew (one of another kind, or not as long as `id`)."""
    cols = dict(msg["columns"])
    for _ in range(rng.randrange(1, 3)):
        name = rng.choice([c.name for c in REQUEST_COLUMNS])
        how = rng.randrange(6)
        raw = cols.get(name)
        if how == 0:
            cols.pop(name, None)
        elif how == 1:
            cols[name] = None
        elif how == 2:
            cols[name] = [1.0, 2.0]
        elif how == 3 and raw:
            cols[name] = raw[:-1]
        elif how == 4 and raw:
            cols[name] = raw + raw[:_ITEM_BYTES[name]]  # one item more
        else:
            cols[name] = _column(name, len(cols["id"]) // 8 if isinstance(cols.get("id"), bytes) else 1, rng)
    return {**msg, "columns": cols}


def _outcome(check: Any) -> tuple[str, str | None, str] | None:
    try:
        check()
    except ProtocolError as e:
        return e.kind, e.path, e.message
    return None


def test_quick_and_one_by_one_checks_agree() -> None:
    rng = random.Random(7)
    refused = 0
    for k in range(3000):
        kind = _KINDS[k % 3]
        msg = _request(kind, rng.choice([0, 1, 2, 5, 40]), rng)
        if k % 4:
            msg = _spoilt(msg, rng)
        whole = _outcome(lambda m=msg: parse_column_request(m))
        one_by_one = _outcome(lambda m=msg, kind=kind: _columns_one_by_one(m["columns"], kind))
        assert whole == one_by_one, msg
        refused += whole is not None
    assert 1000 < refused < 2900  # both kinds of outcome were tried


def test_values_just_beyond_float32_are_refused_and_just_inside_accepted() -> None:
    beyond = math.nextafter(FLOAT32_MAX, math.inf)
    off = [0.25, 0.0, 0.0] * 4
    off[4], off[9] = beyond, -FLOAT32_MAX
    req = parse_column_request({"v": 1, "kind": "offset", "columns": {
        "id": struct.pack("<4Q", 1, 2, 3, 4), "offset": struct.pack("<12d", *off)}})
    assert {i: (e.kind, e.path) for i, e in req.bad.items()} == {1: ("bad_value", "columns.offset[1][1]")}


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf, 1e39, -1e300])
def test_one_bad_value_among_many_is_found(bad: float) -> None:
    rng = np.random.default_rng(3)
    off = rng.uniform(-100.0, 100.0, (300, 3))
    off[217, 2] = bad
    req = parse_column_request({"v": 1, "kind": "offset", "columns": {
        "id": np.arange(1, 301, dtype="<u8").tobytes(), "offset": off.astype("<f8").tobytes()}})
    assert list(req.bad) == [217] and req.bad[217].path == "columns.offset[217][2]"
    assert req.bad[217].kind == ("bad_value" if math.isfinite(bad) else "non_finite")


def test_an_items_first_bad_value_in_column_order_wins() -> None:
    off, vel = [0.25, 0.0, 0.0] * 5, [0.0, 0.0, 0.0] * 5
    off[7], vel[6] = math.nan, 1e40  # item 2: offset and velocity
    vel[14] = math.inf  # item 4: velocity only
    req = parse_column_request({"v": 1, "kind": "offset", "columns": {
        "id": struct.pack("<5Q", *range(1, 6)), "offset": struct.pack("<15d", *off),
        "velocity": struct.pack("<15d", *vel)}})
    assert {i: (e.kind, e.path) for i, e in req.bad.items()} == {
        2: ("non_finite", "columns.offset[2][1]"), 4: ("non_finite", "columns.velocity[4][2]")}


def test_many_large_values_in_range_are_accepted() -> None:
    off = [3.0e38, -3.0e38, 1e38] * 50
    req = parse_column_request({"v": 1, "kind": "offset", "columns": {
        "id": struct.pack("<50Q", *range(1, 51)), "offset": struct.pack("<150d", *off)}})
    assert req.bad == {} and req.n == 50


def test_a_nil_optional_column_is_not_given() -> None:
    req = parse_column_request({"v": 1, "kind": "offset", "columns": {
        "id": struct.pack("<2Q", 1, 2), "offset": struct.pack("<6d", *([0.5] * 6)), "velocity": None}})
    assert sorted(req.arrays) == ["id", "offset"] and req.n == 2 and req.bad == {}


def test_id_lists_are_each_requests_own_ids() -> None:
    def ids_of(*ids: int) -> list[int]:
        req = parse_column_request({"v": 1, "kind": "offset", "columns": {
            "id": struct.pack(f"<{len(ids)}Q", *ids), "offset": bytes(24 * len(ids))}})
        assert req.ids is not None and req.ids == req.arrays["id"].tolist()
        return req.ids

    assert ids_of(5, 2**64 - 1, 5) == [5, 2**64 - 1, 5]
    assert ids_of(7, 8) == [7, 8] and ids_of(5, 2**64 - 1, 5) == [5, 2**64 - 1, 5]
    for k in range(200):  # more id columns than are kept
        assert ids_of(k, k + 1) == [k, k + 1]
    assert ids_of() == []
    # the same id column right again is read into the same list (the core keys its mover lookup on it); after
    # more other columns than the last few, into the same values; one that differs in its last byte is not it
    first = ids_of(9, 10)
    assert ids_of(9, 10) is first
    for k in range(6):
        ids_of(1000 + k)
    assert ids_of(9, 10) == [9, 10] and ids_of(9, 11) == [9, 11] and ids_of(9, 11) is not first
