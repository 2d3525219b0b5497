"""docs/performance.md's targets at the bus's floor (benchmarks/report_service.py), written from a run's
results: each row's figure against its bound, and its verdict."""

from __future__ import annotations

from typing import Any

import pytest

from benchmarks.report_service import service_targets


def _results(rest: float, move: float, raw_rows: list[float], bare_rows: list[float]) -> dict[str, Any]:
    def rounds(rates: list[float]) -> list[dict[str, Any]]:
        return [{"moves_per_s": r, "ratio_to_engine": r / 200_000.0} for r in rates]

    return {
        "instructions": {"column_path": [{"per_move": 32_000.0, "run_batch_per_move": 32_000.0 - rest,
                                          "rest_per_move": rest}]},
        "service": {
            "latency": {"echo": {"median": 300.0}, "engine_echo": {"median": 400.0}, "raw_move": {"median": 460.0},
                        "move": {"median": move}, "ratio_move_to_echo": move / 300.0},
            "batch_workload": {
                "engine": {"moves_per_s": 200_000.0, "cpu_us_per_move": 5.0},
                "bare": {"moves_per_s": bare_rows[1], "ratio_to_engine": 0.7, "rounds": rounds(bare_rows)},
                "service": [{"form": "columns, raw clients", "moves_per_s": raw_rows[1], "ratio_to_engine": 0.6,
                             "cpu_ratio_to_engine": 0.5, "service_cpu_us_per_move": 9.0, "rounds": rounds(raw_rows)}],
            },
        },
    }


def _row(lines: list[str], start: str) -> str:
    (row,) = [line for line in lines if line.startswith(start)]
    return row


def test_each_target_at_the_floor_is_read_against_its_bound() -> None:
    lines = service_targets(_results(2_275.0, 530.0, [90_000.0, 120_000.0, 100_000.0], [100_000.0, 150_000.0, 125_000.0]))
    count = _row(lines, "| the service's own work in a column batch")
    assert "| 2,275 (run_batch 29,725) | met |" in count
    trip = _row(lines, "| one move's round trip")
    # 530 - 400 = 130 over the bound: the service 460 - 400 = 60, the client library 530 - 460 = 70
    assert "530 vs 400 µs: 130 µs over (the service 60 µs" in trip and "client library 70 µs" in trip
    assert trip.endswith("| missed |")
    columns = _row(lines, "| column batches with raw clients")
    # 120,000 / 150,000 = 0.80; the rounds 0.90, 0.80, 0.80
    assert "120,000 vs 150,000 moves/s: 0.80 (rounds 0.90, 0.80, 0.80) | missed |" in columns


def test_targets_met_say_met() -> None:
    lines = service_targets(_results(2_600.0, 430.0, [96_000.0, 97_000.0, 99_000.0], [100_000.0, 100_000.0, 100_000.0]))
    assert _row(lines, "| the service's own work in a column batch").endswith("| missed |")  # 2,600 > 2,500
    assert _row(lines, "| one move's round trip").endswith("| met |")  # 30 µs over
    assert _row(lines, "| column batches with raw clients").endswith("| met |")  # 0.97


def test_the_round_trip_row_says_what_bounds_it_when_the_floor_was_measured() -> None:
    results = _results(2_275.0, 530.0, [90_000.0, 120_000.0, 100_000.0], [100_000.0, 150_000.0, 125_000.0])
    assert "lean handler" not in _row(service_targets(results), "| one move's round trip")  # not measured: no note
    results["service"]["latency"].update(floor_exact={"median": 407.0}, floor_wild={"median": 419.0},
                                         floor_move={"median": 472.0})
    trip = _row(service_targets(results), "| one move's round trip")
    # over the bound of 400: 407 -> 7, 419 -> 19, 472 -> 72
    assert "took +7 µs on a literal key and +19 µs on a wildcard key" in trip and "own move key +72 µs" in trip
    assert trip.endswith("| missed |")


def test_the_walk_from_the_bound_to_one_move_adds_up_step_by_step() -> None:
    from benchmarks.report_service import _floor_walk

    lat = {k: {"median": v} for k, v in (("floor_exact", 407.0), ("floor_wild", 419.0), ("floor_move", 472.0),
                                         ("raw_move", 460.0), ("move", 530.0))}
    walk = _floor_walk(lat, 400.0)
    # 407 - 400 = +7; 419 - 407 = +12; 472 - 419 = +53; 460 - 400 = +60; 530 - 460 = +70
    for step in ("+7 µs on a literal key", "+12 µs more on a key declared with a wildcard", "+53 µs more than the lean",
                 "in +60 µs over the bound", "library added +70 µs"):
        assert step in walk
    del lat["floor_wild"]
    assert _floor_walk(lat, 400.0) == ""  # a run without the floor says nothing of it


def test_the_column_target_is_read_from_the_paired_windows_when_measured() -> None:
    results = _results(2_275.0, 530.0, [90_000.0, 120_000.0, 100_000.0], [100_000.0, 150_000.0, 125_000.0])
    results["service"]["batch_workload"]["paired"] = {
        "window_s": 0.5, "pair_ratios": [0.90, 0.96, 0.94, 0.98, 0.92], "ratio": 0.94,
        "service_moves_per_s": 94_000.0, "bare_moves_per_s": 100_000.0}
    row = _row(service_targets(results), "| column batches with raw clients")
    # 0.94 < 0.95: missed, whatever the rounds (0.90, 0.80, 0.80) say; quartiles of the five ratios by hand:
    # sorted 0.90 0.92 0.94 0.96 0.98, statistics.quantiles' default (exclusive) method: 0.91 and 0.97
    assert "in 0.5 s windows paired with the bound's" in row
    assert "94,000 vs 100,000 moves/s: 0.94, the median of 5 pairs' ratios (quartiles 0.91-0.97)" in row
    assert "rounds, seconds apart: 0.90, 0.80, 0.80" in row and row.endswith("| missed |")
    results["service"]["batch_workload"]["paired"]["ratio"] = 0.96
    assert _row(service_targets(results), "| column batches with raw clients").endswith("| met |")


def test_the_round_trip_verdict_is_the_every_order_figure_when_it_was_measured() -> None:
    results = _results(2_275.0, 530.0, [90_000.0, 120_000.0, 100_000.0], [100_000.0, 150_000.0, 125_000.0])
    results["service"]["latency"]["every_order"] = {"engine_echo": {"median": 420.0}, "raw_move": {"median": 441.0},
                                                "move": {"median": 455.0}}
    trip = _row(service_targets(results), "| one move's round trip")
    # every order: 455 - 420 = 35 over (the service 441 - 420 = 21, the client library 455 - 441 = 14): within 40;
    # the blocks' 530 - 400 = 130 over is given beside it
    assert "455 vs 420 µs, one request at a time in every order: 35 µs over (the service 21 µs, the client library 14 µs)" in trip
    assert "in blocks of the same run, 530 vs 400 µs: 130 µs over" in trip
    assert trip.endswith("| met |")
    results["service"]["latency"]["every_order"]["move"] = {"median": 461.0}  # 41 over
    assert _row(service_targets(results), "| one move's round trip").endswith("| missed |")


def test_the_round_trip_row_gives_the_count_when_the_run_counted_it() -> None:
    results = _results(2_275.0, 530.0, [90_000.0, 120_000.0, 100_000.0], [100_000.0, 150_000.0, 125_000.0])
    results["instructions"]["round_trip"] = [{"bound": 218_000.0, "client": 296_500.0, "client_over_bound": 78_500.0}]
    trip = _row(service_targets(results), "| one move's round trip")
    assert "whole round trip is 296,500 instructions against the bound's 218,000: +78,500" in trip
    assert "protocol's floor" not in trip  # counted before the floor was
    # with the floor counted: 241,000 - 218,000 = +23,000 over the bound; 296,500 - 241,000 = +55,500 own work
    results["instructions"]["round_trip"][0].update({"floor": 241_000.0, "floor_over_bound": 23_000.0,
                                                     "client_over_floor": 55_500.0})
    trip = _row(service_targets(results), "| one move's round trip")
    assert "the protocol's floor, counted the same way, +23,000 over the bound" in trip
    assert "own work is +55,500" in trip


def test_the_series_go_through_every_order_and_every_request_is_timed() -> None:
    from benchmarks.common import round_trips_in_every_order

    calls: list[tuple[str, int]] = []

    def series(name: str) -> Any:
        def ask(i: int) -> object:
            calls.append((name, i))
            return object()
        return ask

    out = round_trips_in_every_order({n: series(n) for n in "abc"}, 7)
    orders = ["abc", "acb", "bac", "bca", "cab", "cba", "abc"]  # the six orders of three, then the first again
    assert calls == [(name, i) for i, order in enumerate(orders) for name in order]
    # over the six orders each series comes right after each other one twice
    pairs = [order[k:k + 2] for order in orders[:6] for k in (0, 1)]
    assert sorted(pairs) == sorted(["ab", "ac", "ba", "bc", "ca", "cb"] * 2)
    assert {n: out[n]["n"] for n in "abc"} == {"a": 7, "b": 7, "c": 7}
    assert all(out[n]["median"] >= 0.0 for n in "abc")


def test_asking_in_every_order_stops_at_a_request_nobody_answered() -> None:
    from benchmarks.common import round_trips_in_every_order

    with pytest.raises(RuntimeError, match="b: request 0 was not answered"):
        round_trips_in_every_order({"a": lambda i: object(), "b": lambda i: []}, 2)


def test_the_round_trip_verdict_is_the_median_of_the_launches_when_they_were_measured() -> None:
    from benchmarks.round_trip_launches import summarise

    results = _results(2_275.0, 530.0, [90_000.0, 120_000.0, 100_000.0], [100_000.0, 150_000.0, 125_000.0])
    results["service"]["latency"]["every_order"] = {"engine_echo": {"median": 420.0}, "raw_move": {"median": 441.0},
                                                "move": {"median": 455.0}}  # 35 over in the run's own launch
    # three launches, move - bound: 350 - 300 = 50, 345 - 310 = 35, 352 - 305 = 47; their median 47 (by hand)
    results["service"]["latency"]["launches"] = summarise([
        {"engine_echo": 300.0, "raw_move": 320.0, "move": 350.0},
        {"engine_echo": 310.0, "raw_move": 322.0, "move": 345.0},
        {"engine_echo": 305.0, "raw_move": 330.0, "move": 352.0}])
    trip = _row(service_targets(results), "| one move's round trip")
    # the service: 20, 12, 25 -> median 20; the client library: 30, 23, 22 -> median 23
    assert "47 µs over, the median of 3 fresh launches" in trip and "launches 35 to 50 µs;" in trip
    assert "the service 20 µs, the client library 23 µs" in trip
    assert "in the run's own launch, 455 vs 420 µs, one request at a time in every order: 35 µs over" in trip
    assert trip.endswith("| missed |")  # 47 > 40, though the run's own launch said 35


def test_the_launches_summary_is_each_launch_over_its_own_bound() -> None:
    from benchmarks.round_trip_launches import summarise

    out = summarise([{"engine_echo": 300.0, "raw_move": 320.0, "move": 338.0},
                     {"engine_echo": 280.0, "raw_move": 310.0, "move": 330.0}])
    assert out["over_bound_each"] == [{"over_bound": 38.0, "service": 20.0, "client": 18.0},
                                      {"over_bound": 50.0, "service": 30.0, "client": 20.0}]
    # quartiles of two values, interpolated a quarter and three quarters of the way: 38 + 12 / 4, 38 + 36 / 4
    assert out["over_bound"] == {"median": 44.0, "min": 38.0, "max": 50.0, "q1": 41.0, "q3": 47.0}
    assert out["client"] == {"median": 19.0, "min": 18.0, "max": 20.0, "q1": 18.5, "q3": 19.5}


def test_the_round_trip_row_gives_the_launches_quartiles() -> None:
    from benchmarks.round_trip_launches import summarise

    results = _results(2_275.0, 530.0, [90_000.0, 120_000.0, 100_000.0], [100_000.0, 150_000.0, 125_000.0])
    # five launches 30, 40, 50, 60, 70 µs over their bounds: the quartiles are the second and fourth, 40 and 60
    results["service"]["latency"]["launches"] = summarise(
        [{"engine_echo": 300.0, "raw_move": 310.0, "move": 300.0 + over} for over in (50.0, 30.0, 70.0, 40.0, 60.0)])
    trip = _row(service_targets(results), "| one move's round trip")
    assert "50 µs over, the median of 5 fresh launches" in trip
    assert "(quartiles 40 to 60, launches 30 to 70 µs;" in trip


def test_the_launches_note_lists_each_launch_and_their_median() -> None:
    from benchmarks.report_launches import launches_note
    from benchmarks.round_trip_launches import summarise

    assert launches_note({}) == ""  # a run without launches says nothing of them
    lat = {"launches": summarise([{"engine_echo": 300.0, "raw_move": 320.0, "move": 338.0},
                                  {"engine_echo": 280.0, "raw_move": 310.0, "move": 330.0},
                                  {"engine_echo": 290.0, "raw_move": 300.0, "move": 335.0}])}
    note = launches_note(lat)
    # over each bound: 38, 50, 45 -> median 45; the service 20, 30, 10 -> 20; the client library 18, 20, 35 -> 20
    assert "in 3 fresh launches" in note and "took +38, +50, +45 µs over each launch's bound" in note
    # quartiles of 38, 45, 50: 41.5 and 47.5, printed to the µs as 42 and 48
    assert "median +45 µs (quartiles 42 to 48, launches 38 to 50 µs; the service +20, the client library +20)" in note


def test_the_launches_floor_is_each_launch_over_its_own_phases_bound() -> None:
    from benchmarks.report_launches import launches_note
    from benchmarks.report_service import service_targets
    from benchmarks.round_trip_launches import summarise

    launches = summarise([
        {"engine_echo": 300.0, "raw_move": 320.0, "move": 350.0, "floor_bound": 310.0, "floor_raw": 305.0,
         "floor_move": 322.0},
        {"engine_echo": 310.0, "raw_move": 322.0, "move": 345.0, "floor_bound": 300.0, "floor_raw": 302.0,
         "floor_move": 315.0},
        {"engine_echo": 305.0, "raw_move": 330.0, "move": 352.0, "floor_bound": 330.0, "floor_raw": 320.0,
         "floor_move": 340.0}])
    # the floor over its own phase's bound: 322 - 310 = 12, 315 - 300 = 15, 340 - 330 = 10 -> median 12;
    # its server 305 - 310 = -5, 2, -10 -> -5; its client 17, 13, 20 -> 17
    assert [e["floor_over_bound"] for e in launches["over_bound_each"]] == [12.0, 15.0, 10.0]
    # quartiles of 10, 12, 15: halfway between the first two and between the last two
    assert launches["floor_over_bound"] == {"median": 12.0, "min": 10.0, "max": 15.0, "q1": 11.0, "q3": 13.5}
    assert launches["floor_service"]["median"] == -5.0 and launches["floor_client"]["median"] == 17.0
    note = launches_note({"launches": launches})
    # the round trip's median over the bound: 50, 35, 47 -> 47, of which 47 - 12 = 35 beyond the floor
    assert "that floor took +12, +15, +10 µs over each launch's bound, median +12 µs (its server -5, its client +17)" in note
    assert "The rest of the 47 µs, 35 µs, is what the service's own work" in note

    results = _results(2_275.0, 530.0, [90_000.0, 120_000.0, 100_000.0], [100_000.0, 150_000.0, 125_000.0])
    results["service"]["latency"]["launches"] = launches
    trip = _row(service_targets(results), "| one move's round trip")
    assert "the protocol's own floor, in the same launches, 12 µs over (section 3)" in trip
    assert trip.endswith("| missed |")


def test_the_one_core_launches_stand_beside_the_verdict() -> None:
    from benchmarks.report_launches import launches_note
    from benchmarks.report_service import service_targets
    from benchmarks.round_trip_launches import summarise

    def launch(bound: float, raw: float, move: float) -> dict[str, float]:
        return {"engine_echo": bound, "raw_move": raw, "move": move, "floor_bound": bound, "floor_raw": bound - 5.0,
                "floor_move": bound + 8.0}

    free = summarise([launch(300.0, 320.0, 350.0), launch(310.0, 330.0, 356.0), launch(320.0, 335.0, 362.0)])
    pinned = summarise([launch(250.0, 262.0, 280.0), launch(254.0, 268.0, 290.0), launch(252.0, 260.0, 284.0)])
    pinned["cpu"] = 0
    results = _results(2_275.0, 530.0, [90_000.0, 120_000.0, 100_000.0], [100_000.0, 150_000.0, 125_000.0])
    results["service"]["latency"].update({"launches": free, "launches_one_core": pinned})
    trip = _row(service_targets(results), "| one move's round trip")
    # unpinned over each bound: 50, 46, 42 -> median 46, missed; pinned 30, 36, 32 -> median 32, quartiles 31 and 34
    assert "46 µs over, the median of 3 fresh launches" in trip and trip.endswith("| missed |")
    assert ("with every process on one core, 32 µs over in 3 launches (quartiles 31 to 34, launches 30 to 36 µs; "
            "the floor 8 µs), beside the verdict") in trip
    note = launches_note({"launches": free, "launches_one_core": pinned})
    # pinned: the service 12, 14, 8 -> 12; the client library 18, 22, 24 -> 22; bounds 250, 254, 252 -> 252,
    # unpinned 300, 310, 320 -> 310
    assert ("3 more launches ran with every process pinned to core 0 (a request then wakes its server on the core it "
            "is already on): `Client.move` took +32 µs over each launch's bound at the median (quartiles 31 to 34, "
            "launches 30 to 36 µs; the service +12, the client library +22, the protocol's floor +8 µs), the bound "
            "itself 252 µs against 310 µs unpinned") in note
    assert "one core" not in launches_note({"launches": free})  # a run without them says nothing of them


def test_launches_recorded_before_the_floor_say_nothing_of_it() -> None:
    from benchmarks.report_launches import launches_note
    from benchmarks.round_trip_launches import summarise

    launches = summarise([{"engine_echo": 300.0, "raw_move": 320.0, "move": 338.0}])
    assert "floor_over_bound" not in launches
    assert "floor" not in launches_note({"launches": launches})


def test_the_handling_table_says_what_the_service_s_steps_cost_over_the_floor_warm_and_after_a_gap() -> None:
    from benchmarks.report_service import _handling

    def both(service: float, floor: float) -> dict[str, Any]:
        return {"service": {"median": service}, "floor": {"median": floor}}

    lines = _handling({"handling_us": {"versus_floor": {"gap_0us": both(8.0, 5.0), "gap_400us": both(35.0, 20.0)}}})
    (note,) = [line for line in lines if line.startswith("The same callback and the protocol's floor")]
    # by hand: warm 8.0 - 5.0 = +3.0; after the gap 35.0 - 20.0 = +15.0, five times as much
    assert "back to back 8.0 against 5.0 µs, the service's own steps +3.0 µs" in note
    assert "35.0 against 20.0 µs, +15.0 µs" in note
    # 20.0 / 5.0 = 4.0 and 35.0 / 8.0 = 4.375; 15.0 / 3.0 = 5.0
    assert "the floor ran 4.0 times slower and the service's callback 4.4 times" in note
    assert "(5.0 times, all told)" in note
    # a run made before the floor was asked says nothing of it
    assert not any("protocol's floor" in line for line in _handling({"handling_us": {"gap_0us": {
        "handler": {"median": 9.0, "p99": 20.0}, "engine": {"median": 3.0}}}}))
