"""A bounded load test: several client processes, thousands of requests.

Every request must be answered exactly once and every state must reach the
subscriber; latency figures are the benchmarks' business, not asserted here.
"""

from __future__ import annotations

from support.service_harness import ServiceProcess, run_load_workers

PROCESSES = 4
REQUESTS = 1000  # per process: 4000 moves in all, some in batches of three


def test_every_request_answered_once_and_no_state_lost() -> None:
    with ServiceProcess() as svc:
        reports = run_load_workers(svc.endpoint, PROCESSES, REQUESTS, batch_every=5, timeout=240.0)
        from clients import Client

        with Client([svc.endpoint]) as c:
            (stats,) = c.stats()
    assert len(reports) == PROCESSES
    for rep in reports:
        i = rep["index"]
        assert rep["errors"] == []
        expected = {f"{i}-{k}" for k in range(REQUESTS)}
        assert set(rep["replies"]) == expected
        assert all(n == 1 for n in rep["replies"].values())
        base = rep["base_seq"]  # zero moves that made sure the subscription was live
        assert rep["final_seq"] == base + REQUESTS
        # every published state of the mover, in order, none missing
        assert rep["states"] == list(range(base + 1, base + REQUESTS + 1))
    lat = stats["latency_ms"]
    # reported, not asserted (see `pytest -s`); the benchmarks own the numbers
    print(f"\nload: {stats['moves']} moves, latency ms p50 {lat['p50']:.3f} p90 {lat['p90']:.3f} "
          f"p99 {lat['p99']:.3f} max {lat['max']:.3f}")
    assert stats["moves"] >= PROCESSES * REQUESTS
    assert stats["errors"].get("busy", 0) == 0
