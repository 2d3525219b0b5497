"""acphys-scene/1: build a World from a scene dict (engine.formats.load opens files and dat directories)."""

from __future__ import annotations

import math
from typing import Any

from ..errors import SceneFormatError
from ..terrain.landblock import LandblockTerrain
from ..settings import RETAIL, EngineSettings
from ..world.indoor_loader import attach_indoor
from ..world.landblock import Landblock
from ..world.world import World

__all__ = ["world_from_scene_dict", "build_landblock", "SCENE_FORMAT"]

SCENE_FORMAT = "acphys-scene/1"


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
        attach_indoor(landblock, lb_data, scene)
    return landblock
