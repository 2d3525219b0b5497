"""The many-movers benchmark (benchmarks/bench_many_movers.py): its arithmetic from hand-worked figures, and
one small real run whose publications are counted at the watcher."""

from __future__ import annotations

from typing import Any

import pytest

from benchmarks import bench_many_movers
from benchmarks.bench_many_movers import per_mover_kb, section

MIB = 2**20


def _row(movers: int, rss_mib: float, register_ms: float, move_ms: float, unknown_ms: float, put_us: float,
         unpublished_ms: float = 0.04, declare_us: float = 50.0, declared_us: float = 2.0,
         held_ms: float = 0.006) -> dict[str, Any]:
    return {"movers": movers, "rss_bytes": int(rss_mib * MIB), "register_ms": register_ms,
            "register_unpublished_ms": register_ms / 2, "move_ms": move_ms,
            "move_unpublished_ms": unpublished_ms, "error_unwatched_unknown_ms": 0.004,
            "error_watched_unknown_ms": unknown_ms, "error_watched_held_first_ms": 0.05, "error_watched_held_ms": held_ms,
            "zenoh_declare_us": declare_us, "zenoh_put_undeclared_us": put_us, "zenoh_put_declared_us": declared_us}


def test_the_memory_each_mover_adds_is_the_rss_growth_over_the_movers_added() -> None:
    rows = [_row(1000, 100.0, 0.1, 0.05, 0.2, 200.0), _row(3000, 104.0, 0.2, 0.05, 0.6, 600.0),
            _row(4000, 104.0, 0.3, 0.05, 0.8, 800.0)]
    # 4 MiB over 2,000 movers: 4 * 1024 KB / 2000 = 2.048 KB; then nothing over 1,000 more
    assert per_mover_kb(rows) == [None, pytest.approx(2.048), pytest.approx(0.0)]


def test_the_section_gives_each_checkpoint_and_how_each_cost_grew() -> None:
    rows = [_row(1000, 100.0, 0.1, 0.05, 0.2, 200.0),
            _row(4000, 106.0, 0.4, 0.06, 0.9, 1000.0, unpublished_ms=0.052, declare_us=250.0, declared_us=2.5,
                 held_ms=0.007)]
    text = "\n".join(section({"sample": 256, "move_repeats": 5, "rows": rows}, "META"))
    # 6 MiB over 3,000 movers: 6 * 1024 / 3000 = 2.048 KB; a register published nowhere is given as half
    assert "| 4,000 | 0.40 | 0.20 | 0.060 | 0.052 | 106 | 2.0 |" in text
    assert "| 1,000 | 0.10 | 0.05 | 0.050 | 0.040 | 100 | - |" in text
    assert "| 4,000 | 0.004 | 0.900 | 0.007 | 250.0 | 1000.0 | 2.5 |" in text
    # 4.0x the movers: register 0.4 / 0.1; the declaration 250 / 50 = 5.0x, 0.25 ms
    assert ("- a register took 4.0x as long, 0.40 ms, and 0.20 ms published nowhere; Zenoh's declaration of one "
            "more key, measured alone, took 0.25 ms (5.0x);") in text
    # publication 0.05 - 0.04 = 10 µs, then 0.06 - 0.052 = 8 µs; published nowhere 0.052 / 0.04 = 1.3x
    assert ("- publishing a pushed move's State added 10 µs at the first count and 8 µs at the last; the move "
            "published nowhere took 1.3x as long;") in text
    # unknown id's error 0.9 / 0.2 = 4.5x; the undeclared put 1000 µs = 1.00 ms, 1000 / 200 = 5.0x; held 6 and 7 µs
    assert ("- an unknown id's error, with someone subscribed, took 4.5x as long, 0.90 ms: it is put on a key "
            "declared for it alone, whose declaration grew as above, where a put on an undeclared key took 1.00 ms "
            "(5.0x); a held mover's took 6 and 7 µs, a put on a declared key 2.0 and 2.5 µs.") in text
    assert "From 1,000 to 4,000 movers (4.0x):" in text and "over 256 of them" in text
    assert "the median of 5 pushes" in text


def test_a_small_run_publishes_what_it_times(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(bench_many_movers, "QUICK_COUNTS", (20, 40))
    monkeypatch.setattr(bench_many_movers, "QUICK_SAMPLE", 8)
    data = bench_many_movers.run(quick=True)
    assert [r["movers"] for r in data["rows"]] == [20, 40] and data["sample"] == 8
    for r in data["rows"]:
        assert all(v > 0 for k, v in r.items() if k != "movers"), r
    # per checkpoint, three pushes of 8 failing moves while the watcher subscribed to errors (unknown ids, then a
    # held mover's twice): 2 * 3 * 8; the push nobody subscribed to sent nothing
    assert data["received"]["error"] == 48
    # at least the 2 checkpoints * 5 published pushes * 8 moves' States (registers' States come too)
    assert data["received"]["state"] >= 2 * bench_many_movers.MOVE_REPEATS * 8 and data["move_repeats"] == 5
