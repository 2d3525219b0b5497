"""The service over a dat directory: landblocks load on demand and unload.

Uses shared/dats/rolling, which carries exactly shared/oracle/scenes/rolling.json.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from clients import Client, ServiceError
from engine import load_scene
from engine.geometry import Position, Vec3
from support.service_harness import ServiceProcess, comparable, human
from support.shared_data import DATS, scene_path, shared_root

ROLLING_DATS = DATS / "rolling"
SCENE = scene_path("rolling")


@pytest.fixture(scope="module")
def client() -> Iterator[Client]:
    shared_root()  # skips without the shared material
    svc = ServiceProcess(Path("unused"))
    i = svc.args.index("--scene")
    svc.args[i:i + 2] = ["--dat-dir", str(ROLLING_DATS)]
    with svc:
        with Client([svc.endpoint], timeout=10.0) as c:
            c.wait_ready()
            yield c


def test_landblocks_load_on_demand_and_unload(client: Client) -> None:
    (lbs,) = client.landblocks()
    assert lbs["loaded"] == []  # nothing until asked
    assert client.load_landblock(0xA9B4) is False
    assert client.load_landblock(0xA9B4) is True
    client.unload_landblock(0xA9B4)
    assert client.landblocks()[0]["loaded"] == []
    assert client.load_landblock(0xA9B4) is False  # a dat world can load it again
    with pytest.raises(ServiceError) as e:
        client.load_landblock(0x1234)
    assert e.value.kind == "landblock_unavailable" and "1234" in e.value.message
    (stats,) = client.stats()
    assert stats["cache"]["hits"] == 1 and stats["cache"]["misses"] == 3
    assert "landblock_cache_misses" in stats["cache"]  # the engine's own counters


def test_moves_equal_the_scene_world(client: Client) -> None:
    world = load_scene(str(SCENE))
    z = world.terrain_height(0xA9B50001, 30.0, 30.0) + 0.5
    start = Position.at(0xA9B50001, Vec3(30.0, 30.0, z))
    st = client.register(human(), start)  # loads A9B5 on demand
    assert 0xA9B5 in client.landblocks()[0]["loaded"]
    mid = world.add_mover(human(), start)
    for _ in range(30):
        st = client.step(st.id, (0.5, 0.4, 0.0), 0.2)
        assert comparable(st) == comparable(world.step(mid, Vec3(0.5, 0.4, 0.0), 0.2))
    assert st.on_walkable
    client.remove(st.id)
