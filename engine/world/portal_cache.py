"""The portal-dat objects a world's landblocks share, built once on first use.

The Environments' CellStructs, GfxObjs and Setups of an acphys-scene/1 scene,
as the client's caches share them; and the scene's frames read at the
precision the dats hold them. Read by the indoor loader and by the static
objects it attaches.
"""

from __future__ import annotations

from typing import Any
from collections.abc import Mapping

from ..cells.cell_struct import CellStruct
from ..errors import SceneFormatError
from ..geometry import Frame, Position, Quat, Vec3
from ..geometry.precision import fl_vec
from ..geometry.single import to_single
from ..objects.gfx_obj import GfxObj, PhysicsPart

__all__ = ["PortalCache", "frame_from_dict", "hex_id"]


def frame_from_dict(d: Mapping[str, Any]) -> Frame:
    """A scene frame, at the single precision the dats (and the client) hold it."""
    o = d.get("origin", [0.0, 0.0, 0.0])
    q = d.get("orientation", [1.0, 0.0, 0.0, 0.0])
    return Frame(
        fl_vec(Vec3(float(o[0]), float(o[1]), float(o[2])), True),
        Quat(to_single(float(q[0])), to_single(float(q[1])), to_single(float(q[2])), to_single(float(q[3]))),
    )


def hex_id(text: Any, what: str) -> int:
    try:
        return int(text, 16)
    except (TypeError, ValueError):
        raise SceneFormatError(f"{what}: expected a hex string, got {text!r}") from None


class PortalCache:
    """Portal-dat objects of one world, built on first use."""

    def __init__(self, scene: Mapping[str, Any]) -> None:
        self.scene = scene
        self._cell_structs: dict[tuple[int, int], CellStruct] = {}
        self._gfx: dict[int, GfxObj] = {}

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

    def gfx_obj(self, gfx_id: int) -> GfxObj:
        g = self._gfx.get(gfx_id)
        if g is None:
            d = self.scene.get("gfx_objs", {}).get(f"{gfx_id:08X}")
            if d is None:
                raise SceneFormatError(f"GfxObj {gfx_id:08X} is not in the scene")
            g = self._gfx[gfx_id] = GfxObj.from_dict(gfx_id, d)
        return g

    def setup(self, setup_id: int) -> Mapping[str, Any]:
        d: Mapping[str, Any] | None = self.scene.get("setups", {}).get(f"{setup_id:08X}")
        if d is None:
            raise SceneFormatError(f"Setup {setup_id:08X} is not in the scene")
        return d

    def parts_of(self, model_id: int, frame: Frame, cell_id: int, scale: float = 1.0) -> list[PhysicsPart]:
        """The placed parts of a GfxObj or Setup model (PartArray with placement
        frames: Resting 0x65 if present, else Default 0; a lone part without a
        placement frame takes the object's frame)."""
        if model_id >> 24 == 0x01:
            return [PhysicsPart(self.gfx_obj(model_id), Position(cell_id, frame), scale)]
        setup = self.setup(model_id)
        placements = setup.get("placement_frames", {})
        placement = placements.get(str(0x65)) or placements.get("0")
        frames = placement.get("frames", []) if placement else []
        scales = setup.get("default_scale")
        parts = []
        for i, part_text in enumerate(setup.get("parts", [])):
            gfx = self.gfx_obj(hex_id(part_text, "setup part"))
            sz = float(scales[i][2]) if scales and i < len(scales) else 1.0
            if i < len(frames):
                child = frame_from_dict(frames[i])
                # AFrame.Combine with the object's scale on the placement offset
                part_frame = Frame(frame.local_to_global(child.origin * scale), frame.orientation * child.orientation)
            else:
                part_frame = frame
            parts.append(PhysicsPart(gfx, Position(cell_id, part_frame), sz * scale))
        return parts
