"""The navigation benchmark's bus part: it asks a real service (a subprocess on the demo scene, loopback)
the pairs it is given in the three forms, and the section renders what it returns.

Expected values: the found counts are the engine's own World.path run here on the same scene (an
independent computation of the service's answers); the request counts are hand counts of start
landblocks and the 64-path limit of docs/protocol.md. No wall-clock assertions."""

from __future__ import annotations

from typing import Any

import pytest

from benchmarks import bench_navigation as bn
from benchmarks.bench_navigation_bus import _by_start_landblock, bus_finding, bus_paths, bus_section
from clients.demo.world import demo_scene_path
from engine import Position, Vec3

#: the demo hills' landblock and one of its outdoor cells
LB, CELL = 0xA9B4, 0xA9B40013


def _on(world: Any, x: float, y: float) -> Position:
    return Position.at(CELL, Vec3(x, y, world.terrain_height(CELL, x, y) + 0.5))


def test_the_batch_forms_send_one_request_per_start_landblock_of_at_most_64_paths() -> None:
    a, b = Position.at(0xA9B40013, Vec3(1.0, 1.0, 0.0)), Position.at(0xAAB40013, Vec3(1.0, 1.0, 0.0))
    groups = _by_start_landblock([(a, b)] * 70 + [(b, a)] * 3)
    # 70 from A9B4 split 64 + 6, 3 from AAB4 in one
    assert sorted(len(g) for g in groups) == [3, 6, 64]
    assert all(len({p.landblock for p, _ in g}) == 1 for g in groups)


def test_the_bus_part_asks_a_service_and_the_section_renders_it() -> None:
    pytest.importorskip("zenoh")
    world = bn._demo()
    pairs = [(_on(world, 50.0, 60.0), _on(world, 60.0, 66.0)), (_on(world, 52.0, 62.0), _on(world, 44.0, 70.0))]
    library = bn._time_paths(world, pairs)
    expected_found = sum(world.path(bn._player(), a, b).found for a, b in pairs)
    bus = bus_paths(demo_scene_path(), bn._player(), {"150 m": pairs}, {"150 m": library})
    row = bus["sets"]["150 m"]
    assert row["pairs"] == 2 and row["requests"] == 1
    assert row["found"] == row["warm_found"] == row["batch_found"] == row["column_found"] == expected_found
    assert row["library_found"] == expected_found
    for key in ("median", "p90", "batched_mean_ms", "columns_mean_ms", "added_ms", "library_median"):
        assert row[key] > 0.0 or key == "added_ms", key
    assert row["medians_added_ms"] == pytest.approx(row["median"] - row["library_median"])
    assert bus["health_ms"] > 0.0 and len(bus["loadavg_before"]) == 3
    text = "\n".join(bus_section(bus) + bus_finding(bus))
    assert "| 150 m |" in text and "**Over the bus.**" in text
    assert "Every form found the same paths as the library." in text


def test_the_section_says_when_the_bus_was_not_measured() -> None:
    assert bus_section(None)[0].startswith("Over the bus: not measured")
    assert "boom" in bus_section({"failed": "boom"})[0]
    assert bus_finding({"failed": "boom"}) == []
