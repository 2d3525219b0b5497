"""Building a landblock's indoor part from acphys-scene/1 dicts.

EnvCells, buildings and static objects of one landblock, with the portal
objects they name (Environments' CellStructs, GfxObjs, Setups) built once per
world and shared, as the client's caches share them.
"""

from __future__ import annotations

from typing import Any
from collections.abc import Mapping

from ..cells.building import BldPortal, BuildingObj
from ..cells.cell_struct import CellStruct
from ..cells.env_cell import CellPortal, EnvCell
from ..errors import SceneFormatError
from ..geometry import Frame, Position, Quat, Vec3
from ..geometry.precision import fl_vec
from ..geometry.single import to_single
from ..geometry.landdefs import outdoor_cell_id
from ..objects.gfx_obj import GfxObj, PhysicsPart

__all__ = ["PortalCache", "attach_indoor", "frame_from_dict"]


def frame_from_dict(d: Mapping[str, Any]) -> Frame:
    """A scene frame, at the single precision the dats (and the client) hold it."""
    o = d.get("origin", [0.0, 0.0, 0.0])
    q = d.get("orientation", [1.0, 0.0, 0.0, 0.0])
    return Frame(
        fl_vec(Vec3(float(o[0]), float(o[1]), float(o[2])), True),
        Quat(to_single(float(q[0])), to_single(float(q[1])), to_single(float(q[2])), to_single(float(q[3]))),
    )


def _hex(text: Any, what: str) -> int:
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
        d = self.scene.get("setups", {}).get(f"{setup_id:08X}")
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
            gfx = self.gfx_obj(_hex(part_text, "setup part"))
            sz = float(scales[i][2]) if scales and i < len(scales) else 1.0
            if i < len(frames):
                child = frame_from_dict(frames[i])
                # AFrame.Combine with the object's scale on the placement offset
                part_frame = Frame(frame.local_to_global(child.origin * scale), frame.orientation * child.orientation)
            else:
                part_frame = frame
            parts.append(PhysicsPart(gfx, Position(cell_id, part_frame), sz * scale))
        return parts


def attach_indoor(landblock: Any, lb_data: Mapping[str, Any], scene: Mapping[str, Any], cache: PortalCache | None = None) -> None:
    """Build the EnvCells, buildings and static objects of `lb_data` into `landblock`."""
    if cache is None:
        cache = PortalCache(scene)

    for ec in lb_data.get("env_cells", []):
        cell_id = _hex(ec.get("id"), "env cell id")
        if cell_id >> 16 != landblock.id or (cell_id & 0xFFFF) < 0x100:
            raise SceneFormatError(f"env cell {cell_id:08X} does not belong to landblock {landblock.id:04X}")
        env_id = _hex(ec.get("environment_id"), f"env cell {cell_id:08X} environment_id")
        cell_struct = cache.cell_struct(env_id, int(ec.get("cell_structure", 0)))
        portals = [
            CellPortal(
                int(p.get("flags", 0)),
                int(p["polygon_id"]),
                _hex(p["other_cell_id"], "portal other_cell_id"),
                int(p.get("other_portal_id", 0xFFFF)),
            )
            for p in ec.get("cell_portals", [])
        ]
        for p in portals:
            if p.polygon_id not in cell_struct.polygons:
                raise SceneFormatError(f"env cell {cell_id:08X}: portal polygon {p.polygon_id} is not in its cell struct")
        visible = [_hex(v, "visible cell") for v in ec.get("visible_cells", [])]
        cell = EnvCell(
            cell_id,
            Position(cell_id, frame_from_dict(ec.get("position", {}))),
            cell_struct,
            portals,
            visible,
            bool(ec.get("seen_outside", False)),
            env_id,
        )
        cell.landblock = landblock
        landblock.env_cells[cell_id] = cell

    for cell in landblock.env_cells.values():
        cell.build_visible_cells(landblock.env_cells.get)

    for b in lb_data.get("buildings", []):
        model_id = _hex(b.get("model_id"), "building model_id")
        frame = frame_from_dict(b.get("frame", {}))
        cell_id = outdoor_cell_id(landblock.id, frame.origin.x, frame.origin.y)
        parts = cache.parts_of(model_id, frame, cell_id)
        doors = [
            BldPortal(
                int(p.get("flags", 0)),
                _hex(p["other_cell_id"], "building portal other_cell_id"),
                int(p.get("other_portal_id", 0)),
                tuple(_hex(s, "stab") for s in p.get("stab_list", [])),
            )
            for p in b.get("portals", [])
        ]
        building = BuildingObj(model_id, parts, doors, int(b.get("num_leaves", 0)))
        land_cell = landblock.get_cell(cell_id)
        building.cell = land_cell
        land_cell.building = building
        landblock.buildings.append(building)

    if lb_data.get("objects") or any(ec.get("static_objects") for ec in lb_data.get("env_cells", [])):
        from .static_objects import attach_static_objects

        attach_static_objects(landblock, lb_data, cache)
