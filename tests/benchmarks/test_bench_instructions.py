"""The instruction-count benchmark (benchmarks/bench_instructions.py): its reading of callgrind's
output, and (where valgrind and a compiled engine are here) that one build counted twice agrees with
itself exactly."""

from __future__ import annotations

from typing import Any

import pytest

from benchmarks import bench_instructions as bi
from benchmarks import common

CALLGRIND_OUT = """# callgrind format
version: 1
creator: callgrind-3.19.0
events: Ir
summary: 5150
fl=(1) engine.c
fn=(1) CPyPy_moves___move_checked
16 5000
fn=(2) other
3 150
totals: 5150
"""


def test_totals_are_read_from_the_totals_line() -> None:
    assert bi.totals_of(CALLGRIND_OUT) == 5000 + 150
    assert bi.totals_of("events: Ir\nsummary: 42\n") == 42  # older files give only the summary line
    with pytest.raises(ValueError):
        bi.totals_of("events: Ir\nfn=(1) f\n16 5000\n")


def test_the_section_says_why_it_was_not_measured() -> None:
    lines = bi.section({"unavailable": "valgrind is not installed"}, "Measured by ...")
    assert "Not measured: valgrind is not installed." in lines


@pytest.mark.skipif(bi.unavailable() is not None, reason=str(bi.unavailable()))
def test_one_build_counted_twice_agrees_with_itself() -> None:
    a = bi._count(common.ROOT, "flat", 40)
    b = bi._count(common.ROOT, "flat", 40)
    assert a["calls"] == b["calls"] > 0
    assert a["instructions"] == b["instructions"] > 1000 * a["calls"]


def test_per_move_is_the_difference_of_the_two_runs_over_their_moves() -> None:
    from benchmarks.instructions_service import per_move

    # 4 and 14 rounds of 200 moves: the 2,000 moves between them took 9,000,000 - 1,000,000 instructions
    assert per_move(1_000_000, 9_000_000, (4, 14), 200) == 4_000.0


def test_the_section_gives_the_column_path_beside_the_traces() -> None:
    data = {"rows": [{"name": "flat", "calls": 10, "instructions": 1000, "per_call": 100.0}],
            "column_path": [{"per_move": 52_000.0, "run_batch_per_move": 39_000.0, "rest_per_move": 13_000.0,
                             "rounds": [4, 14], "moves_per_round": 200}]}
    lines = bi.section(data, "Measured by ...")
    assert "| this checkout | 52,000 | 39,000 | 13,000 |" in lines


@pytest.mark.skipif(bi.unavailable() is not None, reason=str(bi.unavailable()))
def test_the_column_path_count_is_the_engine_and_more() -> None:
    from benchmarks.instructions_service import count_column_path

    c = count_column_path(bi._python_of(common.ROOT))
    assert 0 < c["run_batch_per_move"] < c["per_move"]
    assert c["rest_per_move"] == c["per_move"] - c["run_batch_per_move"]


def test_the_section_gives_one_move_request_beside_the_column_path() -> None:
    data = {"rows": [{"name": "flat", "calls": 10, "instructions": 1000, "per_call": 100.0}],
            "single_move": [{"per_move": 90_000.0, "service_per_move": 55_000.0, "engine_per_move": 35_000.0,
                             "moves": [200, 1200]}]}
    lines = bi.section(data, "Measured by ...")
    assert "| this checkout | 90,000 | 55,000 | 35,000 |" in lines
    assert any("a 200-move and a 1200-move run" in line for line in lines)


def test_one_move_per_move_is_the_difference_of_the_two_runs_over_their_moves() -> None:
    from benchmarks.instructions_single_move import per_move

    # 200 and 1,200 moves: the 1,000 moves between them took 70,000,000 - 20,000,000 instructions
    assert per_move(20_000_000, 70_000_000, (200, 1200)) == 50_000.0


@pytest.mark.skipif(bi.unavailable() is not None, reason=str(bi.unavailable()))
def test_one_move_request_count_is_the_service_and_the_engine() -> None:
    from benchmarks.instructions_single_move import count_single_move

    c = count_single_move(bi._python_of(common.ROOT))  # raises unless every move was answered
    assert 0 < c["service_per_move"] < c["per_move"]
    assert c["engine_per_move"] == c["per_move"] - c["service_per_move"] > 0


def test_the_section_gives_one_client_move_after_the_move_request() -> None:
    data = {"rows": [{"name": "flat", "calls": 10, "instructions": 1000, "per_call": 100.0,
                      "against_per_call": 120.0, "ratio": 100.0 / 120.0}],
            "single_move": [{"per_move": 90_000.0, "service_per_move": 55_000.0, "engine_per_move": 35_000.0,
                             "moves": [200, 1200]}],
            "client_move": [{"per_call": 41_250.5, "calls": [200, 1200]}, {"per_call": 47_706.0, "calls": [200, 1200]}],
            "against": "/elsewhere", "against_commit": "abc1234"}
    lines = bi.section(data, "Measured by ...")
    assert lines.index("| this checkout | 41,250 |") > lines.index("| this checkout | 90,000 | 55,000 | 35,000 |")
    assert "| commit abc1234 | 47,706 |" in lines
    assert any("a 200-call and a 1200-call run" in line for line in lines)


def test_client_move_per_call_is_the_difference_of_the_two_runs_over_their_calls() -> None:
    from benchmarks.instructions_client_move import per_call

    # 200 and 1,200 calls: the 1,000 calls between them took 60,000,000 - 15,000,000 instructions
    assert per_call(15_000_000, 60_000_000, (200, 1200)) == 45_000.0


@pytest.mark.skipif(bi.unavailable() is not None, reason=str(bi.unavailable()))
def test_client_move_count_is_counted() -> None:
    from benchmarks.instructions_client_move import count_client_move

    c = count_client_move(bi._python_of(common.ROOT))  # raises unless every call answered the mover's State
    assert c["per_call"] > 0 and c["calls"] == [200, 1200]


#: one counted round trip as `count_round_trip` gives it, before the floor was counted
_TRIP = {"bound": 218_000.0, "bound_declared": 217_500.0, "service_raw": 305_000.0, "client": 296_000.0,
         "service_over_bound": 87_500.0, "client_over_service_raw": -9_000.0, "client_over_bound": 78_000.0,
         "round_trips": [200, 1200]}
_TRIP_ROW = "| this checkout | 218,000 | 217,500 | 305,000 | 296,000 | 87,500 | -9,000 | 78,000 |"


def _section_of(trip: dict[str, Any]) -> list[str]:
    data = {"rows": [{"name": "flat", "calls": 10, "instructions": 1000, "per_call": 100.0}],
            "client_move": [{"per_call": 41_250.5, "calls": [200, 1200]}], "round_trip": [trip]}
    return bi.section(data, "Measured by ...")


def test_the_section_gives_the_whole_round_trip_after_the_client_move() -> None:
    lines = _section_of(_TRIP)
    assert lines.index(_TRIP_ROW) > lines.index("| this checkout | 41,250 |")
    assert any("a 200- and a 1200-round-trip run" in line for line in lines)
    assert not any("floor, least client" in line for line in lines)  # counted before the floor was


def test_the_section_gives_the_counted_floor_after_the_round_trip() -> None:
    # the floor's figures and their differences from the series above, worked by hand
    lines = _section_of({**_TRIP, "floor_raw": 258_000.0, "floor": 241_000.0, "floor_over_bound": 23_000.0,
                         "floor_service_over_bound": 40_500.0, "floor_client_over_raw": -17_000.0,
                         "client_over_floor": 55_000.0})
    floor_row = "| this checkout | 258,000 | 241,000 | 23,000 | 55,000 |"
    assert lines.index(floor_row) > lines.index(_TRIP_ROW)


@pytest.mark.skipif(bi.unavailable() is not None, reason=str(bi.unavailable()))
def test_the_whole_round_trip_is_counted() -> None:
    from benchmarks.instructions_round_trip import count_round_trip

    c = count_round_trip(bi._python_of(common.ROOT))  # raises unless every round trip was answered
    assert c["round_trips"] == [200, 1200]
    # the service reads, checks, records and packs more than the bare queryable's msgpack and engine call,
    # by far more than the ~20,000 a count moves between runs
    assert c["service_raw"] > c["bound_declared"] + 30_000
    assert c["client_over_bound"] == c["client"] - c["bound"]
    assert c["service_over_bound"] == c["service_raw"] - c["bound_declared"]
    # the floor's server reads, moves and packs as the service does, nothing more; its client packs the map and
    # reads the State as the client library does, nothing more: the whole stack does more than the floor by far
    # more than the ~20,000 a count moves between runs
    assert c["client"] > c["floor"] + 30_000
    assert c["client_over_floor"] == c["client"] - c["floor"]
    assert c["floor_over_bound"] == c["floor"] - c["bound"]
