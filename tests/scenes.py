"""Small synthetic worlds for scenario tests: heights from a function."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import engine
from engine import MoverSpec, SphereSpec

#: height byte b -> b * 0.5 m, so byte 200 = 100 m
HEIGHT_TABLE = [b * 0.5 for b in range(256)]

PLAYER = MoverSpec(
    spheres=[SphereSpec((0.0, 0.0, 0.48), 0.48), SphereSpec((0.0, 0.0, 1.35), 0.48)],
    step_up_height=0.4,
    step_down_height=0.4,
    state=["Contact", "OnWalkable", "IsPlayer", "EdgeSlide"],
    gravity=True,
)


def world_from_heights(
    heights: Callable[[int, int, int, int], int], blocks: Sequence[tuple[int, int]] = ((0xA9, 0xB4),), settings=engine.RETAIL
) -> engine.World:
    """A world whose vertex (x, y) of block (bx, by) has height byte heights(bx, by, x, y)."""
    scene = {
        "format": "acphys-scene/1",
        "name": "synthetic",
        "height_table": HEIGHT_TABLE,
        "landblocks": [
            {"id": f"{bx:02X}{by:02X}", "heights": [heights(bx, by, x, y) for x in range(9) for y in range(9)]}
            for bx, by in blocks
        ],
    }
    return engine.world_from_scene_dict(scene, settings=settings)
