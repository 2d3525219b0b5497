"""Spatial queries per second: sight, ray and ground in this process (World.sight/ray/ground
one at a time and their batched forms) and over the bus (Client.sight/ray/ground one request each, and
one batch request of many, and one column request), on the demo world. Bounded by counts; the service listens on 127.0.0.1."""

from __future__ import annotations

import random
import sys
import time
from collections.abc import Callable
from typing import Any

from .service_harness import Child, demo_scene, free_port
from .common import log

OPS = ("sight", "ray", "ground")


def _queries(world: Any, n: int) -> list[tuple[Any, Any]]:
    """n segments between points 1.6 m over the demo land, 5 to 40 m apart (some cross hills)."""
    from clients.demo.world import global_to_cell
    from engine.geometry import Position, Vec3

    rng = random.Random(14)

    def eye(gx: float, gy: float) -> Any:
        cell, x, y = global_to_cell(gx, gy)
        return Position.at(cell, Vec3(x, y, world.terrain_height(cell, x, y) + 1.6))

    out: list[tuple[Any, Any]] = []
    while len(out) < n:
        gx, gy = rng.uniform(20.0, 170.0), rng.uniform(20.0, 170.0)
        dx, dy = rng.uniform(-40.0, 40.0), rng.uniform(-40.0, 40.0)
        if 5.0 <= (dx * dx + dy * dy) ** 0.5 and 1.0 < gx + dx < 190.0 and 1.0 < gy + dy < 190.0:
            out.append((eye(gx, gy), eye(gx + dx, gy + dy)))
    return out


def _rate(n: int, fn: Callable[[], Any]) -> float:
    t0 = time.perf_counter()
    fn()
    return n / (time.perf_counter() - t0)


def _in_process(world: Any, pairs: list[tuple[Any, Any]]) -> dict[str, dict[str, float]]:
    a, b = [p for p, _ in pairs], [q for _, q in pairs]
    n = len(pairs)
    return {
        "sight": {"single": _rate(n, lambda: [world.sight(p, q) for p, q in pairs]), "batch": _rate(n, lambda: world.sights(a, b))},
        "ray": {"single": _rate(n, lambda: [world.ray(p, q, 0.1) for p, q in pairs]), "batch": _rate(n, lambda: world.rays(a, b, 0.1))},
        "ground": {"single": _rate(n, lambda: [world.ground(p) for p in a]), "batch": _rate(n, lambda: world.grounds(a))},
    }


def _columns(positions: list[Any]) -> tuple[Any, Any]:
    """Cell ids (n,) and origins (n, 3) as numpy columns."""
    import numpy as np

    return (np.array([p.cell_id for p in positions], dtype=np.uint32),
            np.array([p.frame.origin.as_tuple() for p in positions], dtype=np.float64))


def _over_bus(client: Any, pairs: list[tuple[Any, Any]]) -> dict[str, dict[str, float]]:
    a = [p for p, _ in pairs]
    n = len(pairs)
    (fc, fo), (tc, to) = _columns(a), _columns([q for _, q in pairs])
    return {
        "sight": {"single": _rate(n, lambda: [client.sight(p, q) for p, q in pairs]), "batch": _rate(n, lambda: client.sights(pairs)),
                  "columns": _rate(n, lambda: client.sight_columns(fc, fo, tc, to))},
        "ray": {"single": _rate(n, lambda: [client.ray(p, q, 0.1) for p, q in pairs]), "batch": _rate(n, lambda: client.rays(pairs, 0.1)),
                "columns": _rate(n, lambda: client.ray_columns(fc, fo, tc, to, 0.1))},
        "ground": {"single": _rate(n, lambda: [client.ground(p) for p in a]), "batch": _rate(n, lambda: client.grounds(a)),
                   "columns": _rate(n, lambda: client.ground_columns(fc, fo))},
    }


def run(quick: bool) -> dict[str, Any]:
    from clients import Client
    from engine import load_scene

    n = 100 if quick else 1000
    world = load_scene(str(demo_scene()))
    pairs = _queries(world, n)
    log(f"queries: {n} of each kind in process")
    local = _in_process(world, pairs)
    endpoint = f"tcp/127.0.0.1:{free_port()}"
    service = Child([sys.executable, "-m", "service", "--scene", str(demo_scene()), "--listen", endpoint,
                     "--log-level", "WARNING", "--queue", "4096"], "acphys service ready")
    try:
        with Client([endpoint], timeout=60.0) as c:
            c.wait_ready()
            c.sights(pairs[:10])  # warm the routes
            log(f"queries: {n} of each kind over the bus")
            bus = _over_bus(c, pairs)
    finally:
        service.stop()
    blocked = sum(1 for s in world.sights([p for p, _ in pairs], [q for _, q in pairs]) if not s.clear)
    return {"queries": n, "blocked_sights": blocked, "in_process": local, "bus": bus}


def section(data: dict[str, Any], meta: str) -> list[str]:
    """The report's section (benchmarks/report.py); `meta` its line on how it was measured."""
    out = ["## 5. Spatial queries", "", meta, ""]
    if "failed" in data:
        return out + [f"Not measured: {data['failed']}", ""]
    out += [
        f"Queries per second on the demo world: {data['queries']} segments between eyes 1.6 m over the land, "
        f"5 to 40 m apart ({data['blocked_sights']} of the sight lines blocked by the land), each asked one at a "
        "time and as one batch; in this process (`World.sight/ray/ground`, `sights/rays/grounds`) and over the bus "
        "from one client (`Client.sight/ray/ground`, one request each; `sights/rays/grounds`, one batch request; "
        "`sight_columns/ray_columns/ground_columns`, one column request, docs/protocol.md \"Query columns\"). "
        "Ray radius 0.1 m.",
        "",
        "| query | in process, one at a time | in process, batched | bus, one request each | bus, one batch request "
        "| bus, one column request |",
        "|---|---|---|---|---|---|",
    ]
    for op in OPS:
        lo, bu = data["in_process"][op], data["bus"][op]
        cols = f"{bu['columns']:.0f}" if "columns" in bu else "-"
        out.append(f"| {op} | {lo['single']:.0f} | {lo['batch']:.0f} | {bu['single']:.0f} | {bu['batch']:.0f} | {cols} |")
    sweep_ms = 1e3 / max(1.0, data["in_process"]["sight"]["single"])
    return out + ["", (f"Sight and ray cost the engine's sweep (about {sweep_ms:.1f} ms each in this run): over the bus "
                       "one request per query adds the round trip to that, and a batch saves it, leaving the sweep. "
                       "Ground is cheap in the engine, so there the request overhead dominates one query per request "
                       "and a batch recovers most of it; the column form also saves building and reading a map per query."), ""]
