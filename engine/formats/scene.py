"""acphys-scene/1: build a World from a scene file, a scene dict, or a dat directory."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from ..errors import SceneFormatError
from ..terrain.landblock import LandblockTerrain
from ..transition.settings import RETAIL, EngineSettings
from ..world.landblock import Landblock
from ..world.world import World

__all__ = ["load_scene", "world_from_scene_dict", "build_landblock", "SCENE_FORMAT"]

SCENE_FORMAT = "acphys-scene/1"


def load_scene(path: str | Path, settings: EngineSettings = RETAIL) -> World:
    """Load an acphys-scene/1 JSON file, or a directory holding the client's
    `client_cell_1.dat` and `client_portal.dat`, into a World."""
    p = Path(path)
    if p.is_dir():
        from .dat_world import open_dat_world

        return open_dat_world(p, settings=settings)
    try:
        with open(p, encoding="utf-8") as f:
            data = json.load(f)
    except json.JSONDecodeError as e:
        raise SceneFormatError(f"{p}: not valid JSON ({e})") from None
    return world_from_scene_dict(data, settings=settings, name=str(p))


def world_from_scene_dict(data: Any, settings: EngineSettings = RETAIL, name: str = "scene") -> World:
    """Build a World holding every landblock of an acphys-scene/1 dict."""
    if not isinstance(data, dict):
        raise SceneFormatError(f"{name}: a scene is a JSON object")
    fmt = data.get("format")
    if fmt != SCENE_FORMAT:
        raise SceneFormatError(f"{name}: unknown scene format {fmt!r} (expected {SCENE_FORMAT!r})")
    height_table = data.get("height_table")
    if not isinstance(height_table, list) or len(height_table) != 256:
        raise SceneFormatError(f"{name}: height_table must be a list of 256 numbers")
    if not all(isinstance(h, (int, float)) and math.isfinite(h) for h in height_table):
        raise SceneFormatError(f"{name}: height_table holds a non-number or non-finite value")
    landblocks = data.get("landblocks")
    if not isinstance(landblocks, list):
        raise SceneFormatError(f"{name}: landblocks must be a list")
    world = World(settings=settings)
    world.scene = data  # type: ignore[attr-defined]
    for lb_data in landblocks:
        world.add_landblock(build_landblock(lb_data, height_table, data, name))
    return world


def build_landblock(lb_data: Any, height_table: list[float], scene: dict[str, Any], name: str = "scene") -> Landblock:
    """One scene landblock dict -> Landblock (terrain, then indoor cells and objects)."""
    if not isinstance(lb_data, dict):
        raise SceneFormatError(f"{name}: a landblock is a JSON object")
    try:
        lb_id = int(lb_data["id"], 16)
    except (KeyError, TypeError, ValueError):
        raise SceneFormatError(f"{name}: landblock id must be a 4-digit hex string, got {lb_data.get('id')!r}") from None
    if not 0 <= lb_id <= 0xFFFF:
        raise SceneFormatError(f"{name}: landblock id {lb_id:X} out of range")
    try:
        terrain = LandblockTerrain(lb_id, lb_data["heights"], height_table, lb_data.get("terrain"))
    except (KeyError, TypeError, ValueError) as e:
        raise SceneFormatError(f"{name}: landblock {lb_id:04X}: {e}") from None
    landblock = Landblock(terrain, source=lb_data)
    if any(k in lb_data for k in ("env_cells", "buildings", "objects")):
        from ..world.indoor_loader import attach_indoor

        attach_indoor(landblock, lb_data, scene)
    return landblock
