"""The wire-decoding benchmark: its payloads are what it says, the service and msgspec on the bytes give every
bad payload the kind and path the benchmark's table claims (docs/protocol.md's), and the section's finding
follows its figures."""

from __future__ import annotations

import math
from typing import Any

import pytest

from benchmarks.bench_wire_decoding import (
    BAD_CASES,
    CELL,
    MOVES,
    batch_payload,
    column_payload,
    current_batch,
    current_columns,
    current_outcome,
    current_single,
    section,
)
from engine.geometry import Quat, Vec3
from service.protocol.requests import ItemError


@pytest.mark.parametrize("case", BAD_CASES, ids=[c.name for c in BAD_CASES])
def test_the_service_gives_the_kind_and_path_the_table_claims(case: Any) -> None:
    assert current_outcome(case) == case.expected


def test_the_table_covers_the_kinds_the_protocol_names_for_decoding() -> None:
    kinds = {c.expected[0] for c in BAD_CASES if c.expected is not None}
    assert kinds == {"malformed", "too_large", "unsupported_version", "missing_field", "wrong_type", "bad_value",
                     "non_finite"}
    assert any(c.expected is None for c in BAD_CASES)  # an unknown key is ignored, not refused


def test_the_good_payloads_decode_to_the_moves_they_were_built_from() -> None:
    from benchmarks.bench_wire_decoding import single_payload

    one = current_single(single_payload())
    assert (one.id, one.offset, one.to, one.motion) == (7, Vec3(1.0, 0.0, 0.0), None, None)
    items = current_batch(batch_payload()).items
    assert len(items) == MOVES and not any(isinstance(i, ItemError) for i in items)
    # move 1: a target in CELL turned 0.05 rad about z (half-angle cosine and sine)
    assert items[1].to.cell == CELL and items[1].to.orientation == Quat(math.cos(0.025), 0.0, 0.0, math.sin(0.025))
    assert items[2].motion == Vec3(0.0, 4.0 * 0.27, 0.0) and items[2].dt == 1 / 30
    assert items[0].velocity == Vec3(1.5, 0.0, 0.0) and items[0].tag == 0


def test_the_bad_batch_fails_only_its_bad_move() -> None:
    items = current_batch(batch_payload(bad_at=51)).items
    bad = [i for i, item in enumerate(items) if isinstance(item, ItemError)]
    assert bad == [51]
    err = items[51].error
    assert (err.kind, err.path) == ("non_finite", "moves[51].offset[2]")


def test_the_column_payloads_hold_their_moves() -> None:
    off = current_columns(column_payload())
    assert (off.kind, off.n, off.bad) == ("offset", MOVES, {})
    assert off.arrays["offset"][99].tolist() == [0.25, -0.5, 0.0]
    to = current_columns(column_payload(kind="to"))
    assert (to.kind, to.n, to.bad) == ("to", MOVES, {})
    assert to.arrays["to_cell"].tolist() == [CELL] * MOVES


def _data(service_us: float, msgspec_us: float, kept: bool = True) -> dict[str, Any]:
    rows = [{"form": form, "payload": form, "bytes": 10, "items": 1 if form == "single" else MOVES, "same_result": True,
             "us": {"service": service_us, "msgpack_unpackb": 1.0, "msgspec": msgspec_us}}
            for form in ("single", "batch", "columns")]
    errors = [{"name": "x", "form": "map", "expected": ["bad_value", "a"], "service": ["bad_value", "a"],
               "msgspec": ["bad_value", "a"] if kept else ["wrong_type", "a"], "msgspec_said": "Expected `int`"}]
    return {"reps": 3, "rows": rows, "errors": errors, "msgspec_version": "0", "msgpack_version": "1"}


def test_the_finding_follows_the_figures() -> None:
    # the service at 4 µs, the bytes at 2 µs: half the time on both forms
    text = " ".join(section(_data(4.0, 2.0), "meta"))
    assert "1/2.00 to 1/2.00 of the service's time on the map form and 1/2.00 to 1/2.00 on the column form" in text
    assert "every bad payload the kind and path" in text and "NOT" not in text
    text = " ".join(section(_data(4.0, 2.0, kept=False), "meta"))
    assert "mapped to NOT all of them" in text
    skipped = section({"skipped": "msgspec is not installed", "rows": [], "errors": []}, "meta")
    assert "Not compared: msgspec is not installed." in skipped


@pytest.mark.parametrize("case", BAD_CASES, ids=[c.name for c in BAD_CASES])
def test_msgspec_errors_map_to_the_protocol(case: Any) -> None:
    from benchmarks.bench_wire_decoding import candidate_outcome

    assert candidate_outcome(case)[0] == case.expected


def test_msgspec_builds_the_values_the_service_builds() -> None:
    from benchmarks.bench_wire_decoding import _same_result, single_payload

    assert _same_result("single", single_payload())
    assert _same_result("batch", batch_payload())
    assert _same_result("batch", batch_payload(bad_at=51))
    assert _same_result("columns", column_payload())
    assert _same_result("columns", column_payload(kind="to"))
