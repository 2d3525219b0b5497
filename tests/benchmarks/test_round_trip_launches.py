"""benchmarks/round_trip_launches.py: a launch starts its own service and bound, asks the three series in
every order (an unanswered request fails the launch), then the protocol's floor against the same bound,
stops everything and reports each series' median; benchmarks/service_floor.py's least client moves a mover
as a move request says."""

from __future__ import annotations

import math
import os
import sys

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
