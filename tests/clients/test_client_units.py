"""Client-side pieces that need no service: wire building, errors, demo world, PNG, progress."""

from __future__ import annotations

import json


from clients import Move, ServiceError
from clients.demo.world import build_demo_scene, demo_scene_path, global_to_cell, vertex_height
from clients.errors import BusyError
from engine import load_scene
from engine.constants import FLOOR_Z
from engine.geometry import Position, Quat, Vec3


def test_move_to_wire() -> None:
    assert Move(5, offset=(1, 2, 3), tag="t").to_wire() == {"id": 5, "offset": [1.0, 2.0, 3.0], "tag": "t"}
    assert Move(5, motion=Vec3(0.0, 1.0, 0.0), dt=0.1).to_wire() == {"id": 5, "motion": [0.0, 1.0, 0.0], "dt": 0.1}
    to = Position.at(0xA9B40001, Vec3(1.0, 2.0, 3.0), Quat())
    assert Move(5, to=to, velocity=(0, 0, 0)).to_wire() == {
        "id": 5, "to": {"cell": 0xA9B40001, "origin": [1.0, 2.0, 3.0], "orientation": [1.0, 0.0, 0.0, 0.0]},
        "velocity": [0.0, 0.0, 0.0]}
    assert "cell" not in Move(5, to=to, keep_cell=False).to_wire()["to"]


def test_service_error_from_wire() -> None:
    e = ServiceError.from_wire({"kind": "moved", "message": "gone", "landblock": 0xAAB4})
    assert e.kind == "moved" and e.details["landblock"] == 0xAAB4 and str(e) == "moved: gone"
    assert isinstance(ServiceError.from_wire({"kind": "busy", "message": "full"}), BusyError)
    assert ServiceError.from_wire("nonsense").kind == "malformed"


def test_shipped_demo_scene_is_the_generated_one() -> None:
    with open(demo_scene_path(), encoding="utf-8") as f:
        assert json.load(f) == build_demo_scene()


def test_demo_world_has_hills_an_unclimbable_face_and_a_ledge() -> None:
    world = load_scene(str(demo_scene_path()))

    def normal_z(gx: float, gy: float) -> float:
        cell, x, y = global_to_cell(gx, gy)
        lb = world.landblocks[cell >> 16]
        return lb.terrain.normal_at(x, y).z

    heights = [vertex_height(gx, gy) for gx in range(0, 9) for gy in range(0, 9)]
    assert max(heights) - min(heights) >= 8  # hills
    assert normal_z(228.0, 262.0) < FLOOR_Z  # the mesa's west face
    assert normal_z(288.0, 150.0) > FLOOR_Z  # the ramp
    assert normal_z(288.0, 348.0) < FLOOR_Z  # the north ledge


def test_global_to_cell() -> None:
    assert global_to_cell(20.0, 20.0) == (0xA9B40001, 20.0, 20.0)
    assert global_to_cell(200.0, 262.0)[0] == 0xAAB50003
