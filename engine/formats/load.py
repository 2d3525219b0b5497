"""Opening a world from a path: an acphys-scene/1 JSON file or a dat directory.

Above both loaders (scene.py, dat_world.py), so that neither imports the other.
"""

from __future__ import annotations

import json
from pathlib import Path

from ..errors import SceneFormatError
from ..settings import RETAIL, EngineSettings
from ..world.world import World
from .dat_world import open_dat_world
from .scene import world_from_scene_dict

__all__ = ["load_scene"]


def load_scene(path: str | Path, settings: EngineSettings = RETAIL) -> World:
    """Load an acphys-scene/1 JSON file, or a directory holding the client's
    `client_cell_1.dat` and `client_portal.dat`, into a World."""
    p = Path(path)
    if p.is_dir():
        return open_dat_world(p, settings=settings)
    try:
        with open(p, encoding="utf-8") as f:
            data = json.load(f)
    except json.JSONDecodeError as e:
        raise SceneFormatError(f"{p}: not valid JSON ({e})") from None
    return world_from_scene_dict(data, settings=settings, name=str(p))
