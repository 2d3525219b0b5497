"""benchmarks/round_trip_launches.py: a launch starts its own service and bound, asks the three series in
every order (an unanswered request fails the launch), then the protocol's floor against the same bound,
stops everything and reports each series' median; benchmarks/service_floor.py's least client moves a mover
as a move request says."""

from __future__ import annotations

import math
import os
import sys

import pytest

from benchmarks.round_trip_launches import _launch, one_core

SERIES = {"engine_echo", "raw_move", "move", "floor_bound", "floor_raw", "floor_move"}


def test_a_launch_answers_every_series_and_reports_their_medians() -> None:
    medians = _launch(None, 12)  # two requests of each series in each of the six orders
    assert set(medians) == SERIES | {"cpus"}
    for name in SERIES:
        # a loopback round trip: more than nothing, less than the requests' 10 s timeout
        assert math.isfinite(medians[name]) and 0.0 < medians[name] < 10e6, name
    # unpinned, the launch's processes may run wherever this one may
    assert medians["cpus"] == sorted(os.sched_getaffinity(0))


def test_a_one_core_launch_runs_every_process_on_that_core() -> None:
    cpu = one_core()
    assert cpu == min(os.sched_getaffinity(0))
    medians = _launch(None, 12, cpu)
    # read from the launch itself, the service, the bound and the floor: each allowed that core alone
    assert medians["cpus"] == [cpu]
    assert all(math.isfinite(medians[name]) and 0.0 < medians[name] < 10e6 for name in SERIES)


def test_the_floors_least_client_moves_its_mover_east_and_back() -> None:
    from clients import Client

    from benchmarks.service_floor import FLOOR_EXACT_KEY, floor_client_move
    from benchmarks.service_harness import Child, bench_walker, free_port, start_position

    port = free_port()
    floor = Child([sys.executable, "-m", "benchmarks.service_floor", str(port)], "floor ready")
    try:
        with Client([f"tcp/127.0.0.1:{port}"], timeout=30.0) as c:
            start = start_position(0)
            mid = c.register(bench_walker(), start).id
            move = floor_client_move(c.session, FLOOR_EXACT_KEY, mid)
            east, back = move(0), move(1)
            # the floor's handler moved the mover itself: the service's own record says where it ended
            now, _ = c.get(mid)
    finally:
        floor.stop()
    o0, o1, o2 = start.frame.origin, east.result.position.frame.origin, back.result.position.frame.origin
    # the benchmark's scene is flat and open: 0.2 m east is taken whole, and back again (float32 origins)
    assert east.id == back.id == mid and east.ok and back.ok
    assert math.isclose(o1.x - o0.x, 0.2, abs_tol=1e-4) and math.isclose(o1.y, o0.y, abs_tol=1e-4)
    assert math.isclose(o2.x, o0.x, abs_tol=1e-4) and math.isclose(o2.y, o0.y, abs_tol=1e-4)
    # each move counted once (seq one more each), and the service's record holds the last one
    assert back.seq == east.seq + 1 and now.seq == back.seq
    assert now.result.position.cell_id == back.result.position.cell_id and now.result.position.frame.origin.x == o2.x


def _launch_of(bound: float, raw: float, move: float) -> dict[str, float]:
    return {"engine_echo": bound, "raw_move": raw, "move": move}


def test_launch_pairs_are_paired_launch_by_launch() -> None:
    from benchmarks.round_trip_launches import paired

    pairs = [(_launch_of(300.0, 320.0, 340.0), _launch_of(310.0, 325.0, 346.0)),   # over: A 40, B 36
             (_launch_of(290.0, 300.0, 335.0), _launch_of(300.0, 315.0, 350.0)),   # A 45, B 50
             (_launch_of(305.0, 330.0, 347.0), _launch_of(295.0, 310.0, 333.0))]   # A 42, B 38
    out = paired(pairs)
    # B - A: -4, +5, -4 -> median -4, mean -1, B lower in 2 of 3; each arm's own median 42 and 38
    assert out["over_bound"] == {"a": 42.0, "b": 38.0, "difference": -4.0, "mean": -1.0, "b_lower": 2, "pairs": 3}
    # the service's share (raw - bound): A 20, 10, 25; B 15, 15, 15 -> differences -5, +5, -10
    assert out["service"]["difference"] == -5.0 and out["service"]["b_lower"] == 2
    assert "floor_over_bound" not in out  # launches without the floor's phase say nothing of it
    assert paired([]) == {}


def test_launch_pairs_alternate_which_tree_goes_first(monkeypatch: pytest.MonkeyPatch) -> None:
    from pathlib import Path

    import benchmarks.round_trip_launches as launches

    ran: list[tuple[Path | None, int, int | None]] = []

    def launch(tree: Path | None, requests: int, cpu: int | None = None) -> dict[str, float]:
        ran.append((tree, requests, cpu))
        # tree A's launches 40 over their bound, tree B's 30, whichever runs first
        return _launch_of(300.0, 310.0, 340.0 if tree == Path("/a") else 330.0)

    monkeypatch.setattr(launches, "_launch", launch)
    out = launches.launch_pairs(Path("/a"), Path("/b"), 3, 60, 0)
    assert [tree for tree, _, _ in ran] == [Path(p) for p in ("/a", "/b", "/b", "/a", "/a", "/b")]
    assert all(requests == 60 and cpu == 0 for _, requests, cpu in ran)
    # each pair's launches kept with their own tree, whichever ran first
    assert [(a["move"], b["move"]) for a, b in out["pairs"]] == [(340.0, 330.0)] * 3
    assert out["paired"]["over_bound"]["difference"] == -10.0 and out["paired"]["over_bound"]["b_lower"] == 3
