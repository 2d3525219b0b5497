"""The built-in demo world: four landblocks of generated terrain.

Deterministic (no randomness), so `clients/demo/demo.json` is exactly what
`build_demo_scene()` returns; a test checks the two agree. The layout, in
global metres over the 384 m x 384 m square of landblocks A9B4 (south-west),
AAB4, A9B5 and AAB5 (north-east):

- rolling hills everywhere at about 40 m;
- a mesa 90 m high in the north-east (x 240..336, y 216..336), whose west
  face rises 50 m over one 24 m cell (normal z about 0.43, far below
  FloorZ 0.664: a slope nothing can walk up);
- a ramp up to the mesa from the south (x 264..312, y 72..216), about 8 m
  per cell, easily walkable;
- the mesa's north edge drops 50 m in one cell: a ledge to walk off.
"""

from __future__ import annotations

import json
import math
from importlib import resources
from pathlib import Path
from typing import Any

__all__ = [
    "DEMO_LANDBLOCKS",
    "ORIGIN_LANDBLOCK",
    "MESA_TOP",
    "build_demo_scene",
    "demo_scene_path",
    "global_to_cell",
    "write_demo_scene",
]

ORIGIN_LANDBLOCK = 0xA9B4  # the south-west landblock: global (0, 0)
DEMO_LANDBLOCKS = (0xA9B4, 0xAAB4, 0xA9B5, 0xAAB5)
MESA_TOP = 90
_MESA_X = range(10, 15)  # global vertex columns of the mesa top
_MESA_Y = range(9, 15)
_RAMP_X = range(11, 14)
_RAMP_Y = range(3, 9)  # vertex rows climbing from the hills to the top


def _hills(gx: int, gy: int) -> float:
    return 40.0 + 5.0 * math.sin(gx * 0.8) * math.cos(gy * 0.6) + 3.0 * math.sin(0.5 * gx + 0.9 * gy)


def vertex_height(gx: int, gy: int) -> int:
    """Height in metres (= height byte: the table is 1 m per step) of global vertex (gx, gy)."""
    if gx in _MESA_X and gy in _MESA_Y:
        return MESA_TOP
    base = _hills(gx, gy)
    if gx in _RAMP_X and gy in _RAMP_Y:
        start = _hills(gx, _RAMP_Y.start)
        t = (gy - _RAMP_Y.start) / (_MESA_Y.start - _RAMP_Y.start)
        return int(round(start + (MESA_TOP - start) * t))
    return int(round(base))


def build_demo_scene() -> dict[str, Any]:
    """The demo scene as an acphys-scene/1 dict."""
    ox, oy = ORIGIN_LANDBLOCK >> 8, ORIGIN_LANDBLOCK & 0xFF
    landblocks = []
    for lb in DEMO_LANDBLOCKS:
        bx, by = (lb >> 8) - ox, (lb & 0xFF) - oy
        heights = [vertex_height(bx * 8 + x, by * 8 + y) for x in range(9) for y in range(9)]
        landblocks.append({"id": f"{lb:04X}", "heights": heights})
    return {
        "format": "acphys-scene/1",
        "name": "acphys-demo",
        "height_table": [float(i) for i in range(256)],
        "landblocks": landblocks,
    }


def global_to_cell(x: float, y: float) -> tuple[int, float, float]:
    """Global demo metres to (outdoor cell id, landblock-local x, y)."""
    bx, by = int(x // 192.0), int(y // 192.0)
    bx, by = min(max(bx, 0), 1), min(max(by, 0), 1)
    lx, ly = x - bx * 192.0, y - by * 192.0
    lb = ((ORIGIN_LANDBLOCK >> 8) + bx) << 8 | ((ORIGIN_LANDBLOCK & 0xFF) + by)
    cx, cy = min(max(int(lx // 24.0), 0), 7), min(max(int(ly // 24.0), 0), 7)
    return (lb << 16) | (cx * 8 + cy + 1), lx, ly


def demo_scene_path() -> Path:
    """Where the shipped demo scene file is (package data of `clients`)."""
    return Path(str(resources.files("clients").joinpath("demo", "demo.json")))


def write_demo_scene(path: Path | None = None) -> Path:
    """Regenerate the shipped file (run `python -m clients.demo_world`)."""
    path = path or demo_scene_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    scene = build_demo_scene()
    with open(path, "w", encoding="utf-8") as f:
        json.dump(scene, f, separators=(",", ":"))
        f.write("\n")
    return path


if __name__ == "__main__":
    print(write_demo_scene())
