"""Building the World the service holds: a scene file or a dat directory."""

from __future__ import annotations

import os
from typing import Any

__all__ = ["open_world"]


def open_world(scene: str | None = None, dat_dir: str | None = None) -> Any:
    """The engine's World for a scene file (acphys-scene/1 JSON) or a dat directory.

    The engine is imported here, not at module load, so the bus code can be
    imported (and its argument parser shown) without building anything.
    """
    if (scene is None) == (dat_dir is None):
        raise ValueError("give exactly one of a scene file or a dat directory")
    from engine import load_scene, open_dat_world

    if dat_dir is not None:
        if not os.path.isdir(dat_dir):
            raise FileNotFoundError(f"dat directory {dat_dir!r} does not exist")
        return open_dat_world(dat_dir)
    assert scene is not None
    if not os.path.isfile(scene):
        raise FileNotFoundError(f"scene file {scene!r} does not exist")
    return load_scene(scene)
