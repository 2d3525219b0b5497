"""`acphys ground / sight / ray / place`, run as a user would (a subprocess) against a demo service."""

from __future__ import annotations

import json
from collections.abc import Iterator

import pytest

from support.service_harness import ServiceProcess, demo_world
from test_cli import acphys

WORLD = demo_world()
CELL = 0xA9B40001  # outdoor cell x 0..24, y 0..24


def terrain(x: float, y: float) -> float:
    return WORLD.terrain_height(CELL, x, y)


@pytest.fixture(scope="module")
def service() -> Iterator[ServiceProcess]:
    with ServiceProcess() as svc:
        yield svc


def test_ground_prints_the_terrain_height(service: ServiceProcess) -> None:
    r = acphys("ground", "A9B40001", "12", "7", str(terrain(12.0, 7.0) + 3.0), "--connect", service.endpoint, "--json")
    assert r.returncode == 0, r.stderr
    g = json.loads(r.stdout)
    assert g["z"] == pytest.approx(terrain(12.0, 7.0), abs=1e-4) and g["cell"] == CELL
    r = acphys("ground", "A9B40001", "12", "7", str(terrain(12.0, 7.0) + 3.0), "--connect", service.endpoint)
    assert r.returncode == 0, r.stderr
    z_line = next(ln for ln in r.stdout.splitlines() if ln.strip().startswith("z "))
    assert float(z_line.split()[1]) == pytest.approx(terrain(12.0, 7.0), abs=1e-3)


def test_sight_clear_above_and_blocked_into_the_ground(service: ServiceProcess) -> None:
    top = max(terrain(4.0, 4.0), terrain(20.0, 20.0)) + 20.0
    r = acphys("sight", "--from", "A9B40001", "4", "4", str(top), "--to", "A9B40001", "20", "20", str(top),
               "--connect", service.endpoint)
    assert r.returncode == 0, r.stderr
    assert "clear" in r.stdout and "blocked" not in r.stdout
    r = acphys("sight", "--from", "A9B40001", "4", "4", str(top), "--to", "A9B40001", "20", "20",
               str(terrain(20.0, 20.0) - 5.0), "--connect", service.endpoint, "--json")
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert s["clear"] is False and s["blocker"] == {"kind": "terrain", "object_id": None}


def test_ray_and_place(service: ServiceProcess) -> None:
    z = terrain(12.0, 12.0)
    r = acphys("ray", "--from", "A9B40001", "12", "12", str(z + 3.0), "--to", "A9B40001", "12", "12", str(z - 3.0),
               "--radius", "0.1", "--connect", service.endpoint, "--json")
    assert r.returncode == 0, r.stderr
    hit = json.loads(r.stdout)
    # straight down onto the land: the sphere's centre stops one radius above it (the slope tilts it a little)
    assert hit["hit"] is True and hit["blocker"]["kind"] == "terrain"
    assert z < hit["position"]["origin"][2] <= z + 0.1 / hit["normal"][2] + 1e-3
    r = acphys("place", "A9B40001", "12", "12", str(z + 0.5), "--connect", service.endpoint)
    assert r.returncode == 0, r.stderr
    assert "OK" in r.stdout


def test_query_errors_are_clear(service: ServiceProcess) -> None:
    r = acphys("ground", "A9B40123", "12", "7", "50", "--connect", service.endpoint)
    assert r.returncode == 1 and "unknown_cell" in r.stderr
    r = acphys("ground", "XYZ", "12", "7", "50", "--connect", service.endpoint)
    assert r.returncode == 2 and "CELL X Y Z" in r.stderr
