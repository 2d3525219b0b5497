"""The portal-dat objects a world's landblocks share, built once on first use.

The models of an acphys-scene/1 scene (Setups and GfxObjs, through the one
model loader, engine.objects.setup.ModelLibrary) and the Environments'
CellStructs, as the client's caches share them. Read by the indoor loader and
by the static objects it attaches.
"""

from __future__ import annotations

from typing import Any
from collections.abc import Mapping

from ..cells.cell_struct import CellStruct
from ..errors import SceneFormatError
from ..objects.setup import ModelLibrary, frame_from_dict

__all__ = ["PortalCache", "frame_from_dict", "hex_id"]


def hex_id(text: Any, what: str) -> int:
    try:
        return int(text, 16)
    except (TypeError, ValueError):
        raise SceneFormatError(f"{what}: expected a hex string, got {text!r}") from None


class PortalCache(ModelLibrary):
    """Portal-dat objects of one world, built on first use: the models
    (Setups, GfxObjs) and the Environments' CellStructs."""

    def __init__(self, scene: Mapping[str, Any]) -> None:
        super().__init__(scene)
        self._cell_structs: dict[tuple[int, int], CellStruct] = {}

    def cell_struct(self, env_id: int, index: int) -> CellStruct:
        key = (env_id, index)
        cs = self._cell_structs.get(key)
        if cs is None:
            env = self.scene.get("environments", {}).get(f"{env_id:08X}")
            if env is None:
                raise SceneFormatError(f"environment {env_id:08X} is not in the scene")
            d = env.get("cell_structs", {}).get(str(index))
            if d is None:
                raise SceneFormatError(f"environment {env_id:08X} has no cell struct {index}")
            cs = self._cell_structs[key] = CellStruct.from_dict(d)
        return cs
