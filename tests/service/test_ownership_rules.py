"""Ownership's rule form (X stripes), splitting landblocks between workers, and the
merge of the workers' Health/Stats into one answer. No bus."""

from __future__ import annotations

import argparse
import math
import os
import random

import pytest
import zenoh

from service.scaleout.aggregate import WorkerView, merge_health, merge_landblocks, merge_stats, merged_window
from service.ownership import Ownership
from service.scaleout.workers import worker_count


def test_x_stripe_parses_and_owns_by_the_high_byte() -> None:
    o = Ownership.parse("x=A0-AA")
    assert o.x_range == (0xA0, 0xAA) and not o.everything
    assert o.owns(0xA000) and o.owns(0xA9B4) and o.owns(0xAAFF)
    assert not o.owns(0x9FFF) and not o.owns(0xAB00) and not o.owns(0x0A9B)
    assert o.to_wire() == {"x_min": 0xA0, "x_max": 0xAA} and o.to_text() == "x=A0-AA"
    assert Ownership.parse(o.to_text()) == o
    assert Ownership.parse("X=00-ff").everything  # the whole map is `*`
    for bad in ("x=AA-A0", "x=A-FF", "x=00FF", "x=GG-HH", "x=00-100"):
        with pytest.raises(ValueError):
            Ownership.parse(bad)


def test_x_stripe_keys_match_exactly_its_landblocks() -> None:
    """Zenoh's own key matching, over every landblock id: the declared chunk prefixes reach the
    owned landblocks' keys and no other."""
    for lo, hi in ((0x00, 0x7F), (0x80, 0xFF), (0xA3, 0xB1), (0x55, 0x55), (0x0F, 0x10)):
        o = Ownership.x_stripe(lo, hi)
        decl = [zenoh.KeyExpr(f"acphys/lb/{part}/move") for part in o.key_parts()]
        rng = random.Random(lo * 256 + hi)
        for lb in [*range(0, 0x10000, 0x0101), *(rng.randrange(0x10000) for _ in range(300))]:
            key = zenoh.KeyExpr(f"acphys/lb/{lb:04X}/move")
            want = lo <= lb >> 8 <= hi
            assert any(d.intersects(key) for d in decl) == want, (o.key_parts(), f"{lb:04X}")
    # whole hex digits are one chunk prefix each: few declarations
    assert Ownership.x_stripe(0x00, 0x7F).key_parts() == [f"{d:X}$*" for d in range(8)]
    assert Ownership.x_stripe(0xA3, 0xB1).key_parts() == [f"A{d:X}$*" for d in range(3, 16)] + ["B0$*", "B1$*"]


def test_split_a_scene_into_contiguous_runs() -> None:
    demo = [0xA9B4, 0xA9B5, 0xAAB4, 0xAAB5]
    assert Ownership().split(2, demo) == [Ownership(frozenset({0xA9B4, 0xA9B5})), Ownership(frozenset({0xAAB4, 0xAAB5}))]
    # a 3 x 3 block into 3: one column each, west to east
    block = [(x << 8) | y for x in (0x10, 0x11, 0x12) for y in (0x20, 0x21, 0x22)]
    parts = Ownership().split(3, reversed(block))
    assert [sorted(p.landblocks or ()) for p in parts] == [block[0:3], block[3:6], block[6:9]]
    # more workers than landblocks: one each
    assert len(Ownership().split(8, demo)) == 4
    # an explicit list splits the same way; every landblock goes to exactly one part
    parts = Ownership.parse("0101,0102,0201,0202,0301").split(2)
    assert [sorted(p.landblocks or ()) for p in parts] == [[0x0101, 0x0102], [0x0201, 0x0202, 0x0301]]


def test_split_an_unknown_world_into_x_stripes() -> None:
    assert Ownership().split(2) == [Ownership.x_stripe(0x00, 0x7F), Ownership.x_stripe(0x80, 0xFF)]
    three = Ownership().split(3)
    assert [p.x_range for p in three] == [(0x00, 0x54), (0x55, 0xA9), (0xAA, 0xFF)]
    for lb in range(0, 0x10000, 0x0107):  # every landblock owned by exactly one stripe
        assert sum(p.owns(lb) for p in three) == 1
    assert [p.x_range for p in Ownership.parse("x=A0-A3").split(2)] == [(0xA0, 0xA1), (0xA2, 0xA3)]
    assert Ownership().split(1) == [Ownership()]


def test_worker_count() -> None:
    assert worker_count("3") == 3 and worker_count(None) == 1
    assert worker_count("auto") == len(os.sched_getaffinity(0))
    for bad in ("0", "-2", "many"):
        with pytest.raises(argparse.ArgumentTypeError):
            worker_count(bad)


def test_merged_latency_is_over_every_sample() -> None:
    a = [k / 1000.0 for k in range(1, 51)]  # 1..50 ms
    b = [k / 1000.0 for k in range(51, 101)]  # 51..100 ms
    s = merged_window([a, b], [70, 80])
    # nearest rank over 1..100 ms, computed by hand: p50 is the 50th value, p90 the 90th
    assert s["p50"] == pytest.approx(50.0) and s["p90"] == pytest.approx(90.0) and s["max"] == pytest.approx(100.0)
    assert s["mean"] == pytest.approx(50.5) and s["window"] == 100 and s["count"] == 150
    assert merged_window([], [])["p50"] == 0.0


def _views(alive: tuple[bool, bool] = (True, True)) -> list[WorkerView]:
    return [WorkerView(0, Ownership(frozenset({0xA9B4})), 100, alive[0], "w0"),
            WorkerView(1, Ownership(frozenset({0xAAB4})), 101, alive[1], "w1")]


def test_merge_health_adds_up_and_reports_a_dead_worker() -> None:
    base = {"instance": "parent", "protocol": 1, "publish": ["each", "batch"], "uptime_s": 3.0}
    replies = {0: {"queue_depth": 2, "queue_capacity": 1024, "movers": 5},
               1: {"queue_depth": 1, "queue_capacity": 1024, "movers": 7}}
    h = merge_health(base, replies, _views(), draining=False)
    assert h["status"] == "ok" and h["workers"] == 2 and h["workers_ok"] == 2
    assert (h["queue_depth"], h["queue_capacity"], h["movers"]) == (3, 2048, 12)
    assert h["instance"] == "parent" and [w["status"] for w in h["worker_processes"]] == ["ok", "ok"]
    dead = _views((True, False))
    dead[1].exit_code = -9
    h = merge_health(base, {0: replies[0]}, dead, draining=False)
    assert h["status"] == "degraded" and h["workers"] == 2 and h["workers_ok"] == 1 and h["movers"] == 5
    assert h["worker_processes"][1]["status"] == "dead" and h["worker_processes"][1]["exit_code"] == -9
    # alive but silent is degraded too
    assert merge_health(base, {1: replies[1]}, _views(), draining=False)["worker_processes"][0]["status"] == "unresponsive"
    assert merge_health(base, replies, _views(), draining=True)["status"] == "draining"


def test_merge_stats_sums_counters_but_not_the_parents_own_queries() -> None:
    base = {"instance": "parent", "protocol": 1, "publish": ["each"], "uptime_s": 3.0}
    w0 = {"requests": {"move": 10, "health": 4, "stats": 2}, "moves": 30, "errors": {"unknown_mover": 1},
          "handovers": {"out": 1, "in": 0, "failed": 0}, "cache": {"hits": 1, "misses": 2, "landblock_loads": 4},
          "loaded_landblocks": [0xA9B4, 0xAAB4], "latency_ms": {"count": 30}, "engine_ms": {"count": 30},
          "queue_depth": 0, "queue_capacity": 10, "movers": 1}
    w1 = {"requests": {"move": 5, "handover": 1, "stats": 2}, "moves": 12, "errors": {"busy": 2, "unknown_mover": 1},
          "handovers": {"out": 0, "in": 1, "failed": 0}, "cache": {"hits": 3, "misses": 0, "landblock_loads": 4},
          "loaded_landblocks": [0xAAB4, 0xAAB5], "latency_ms": {"count": 12}, "engine_ms": {"count": 12},
          "queue_depth": 0, "queue_capacity": 10, "movers": 2}
    samples = {0: {"latency_s": [0.001] * 3, "engine_s": [0.0005] * 3}, 1: {"latency_s": [0.003], "engine_s": [0.001]}}
    s = merge_stats(base, {"requests": {"stats": 1}, "errors": {}}, {0: w0, 1: w1}, samples, _views(), False)
    assert s["requests"] == {"move": 15, "handover": 1, "stats": 1}
    assert s["moves"] == 42 and s["errors"] == {"unknown_mover": 2, "busy": 2}
    assert s["handovers"] == {"out": 1, "in": 1, "failed": 0}
    assert s["cache"] == {"hits": 4, "misses": 2, "landblock_loads": 8}
    # what the workers serve: w0's AAB4 is a copy (w1 owns it), and nobody owns AAB5
    assert s["loaded_landblocks"] == [0xA9B4, 0xAAB4] and s["movers"] == 3 and s["workers"] == 2
    assert s["latency_ms"]["count"] == 42 and s["latency_ms"]["window"] == 4
    assert math.isclose(s["latency_ms"]["mean"], (3 * 1.0 + 3.0) / 4) and s["latency_ms"]["max"] == pytest.approx(3.0)
    assert s["engine_ms"]["p50"] == pytest.approx(0.5)
    assert "status" not in s and s["instance"] == "parent"


def test_merge_landblocks_lists_what_the_owners_serve() -> None:
    """Every worker holds a scene's every landblock; once AAB4's owner (w1) has unloaded it, the service
    serves it no more, though w0 still has its copy: the face lists A9B4 only, each worker its own list."""
    base = {"instance": "parent", "owned": "*"}
    replies = {0: {"loaded": [0xA9B4, 0xAAB4]}, 1: {"loaded": [0xA9B4]}}
    got = merge_landblocks(base, replies, _views())
    assert got["loaded"] == [0xA9B4] and got["instance"] == "parent" and got["owned"] == "*"
    assert got["workers"] == 2
    assert got["worker_processes"] == [{"index": 0, "owned": [0xA9B4], "loaded": [0xA9B4, 0xAAB4]},
                                       {"index": 1, "owned": [0xAAB4], "loaded": [0xA9B4]}]
    # both owners with theirs loaded: both served; a silent worker's landblocks are not
    both = {0: {"loaded": [0xA9B4, 0xAAB4]}, 1: {"loaded": [0xA9B4, 0xAAB4]}}
    assert merge_landblocks(base, both, _views())["loaded"] == [0xA9B4, 0xAAB4]
    assert merge_landblocks(base, {0: both[0]}, _views())["loaded"] == [0xA9B4]
    # an X stripe owns by the id's high byte
    stripes = [WorkerView(0, Ownership.x_stripe(0x00, 0xA9), 100, True), WorkerView(1, Ownership.x_stripe(0xAA, 0xFF), 101, True)]
    assert merge_landblocks(base, {0: {"loaded": [0xA9B4, 0xAAB4]}, 1: {"loaded": [0xAAB5]}}, stripes)["loaded"] == \
        [0xA9B4, 0xAAB5]
