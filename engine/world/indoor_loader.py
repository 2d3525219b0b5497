"""Building a landblock's indoor part from acphys-scene/1 dicts.

EnvCells, buildings and static objects of one landblock, with the portal
objects they name (Environments' CellStructs, GfxObjs, Setups) built once per
world and shared, as the client's caches share them.
"""

from __future__ import annotations

from typing import Any
from collections.abc import Mapping

from ..cells.building import BldPortal, BuildingObj
from ..cells.env_cell import CellPortal, EnvCell
from ..errors import SceneFormatError
from ..geometry import Position
from ..geometry.landdefs import outdoor_cell_id
from .landblock import Landblock
from .portal_cache import PortalCache, frame_from_dict, hex_id
from .static_objects import attach_static_objects

__all__ = ["attach_indoor"]


def attach_indoor(landblock: Landblock, lb_data: Mapping[str, Any], scene: Mapping[str, Any], cache: PortalCache | None = None) -> None:
    """Build the EnvCells, buildings and static objects of `lb_data` into `landblock`."""
    if cache is None:
        cache = PortalCache(scene)

    for ec in lb_data.get("env_cells", []):
        cell_id = hex_id(ec.get("id"), "env cell id")
        if cell_id >> 16 != landblock.id or (cell_id & 0xFFFF) < 0x100:
            raise SceneFormatError(f"env cell {cell_id:08X} does not belong to landblock {landblock.id:04X}")
        env_id = hex_id(ec.get("environment_id"), f"env cell {cell_id:08X} environment_id")
        cell_struct = cache.cell_struct(env_id, int(ec.get("cell_structure", 0)))
        portals = [
            CellPortal(
                int(p.get("flags", 0)),
                int(p["polygon_id"]),
                hex_id(p["other_cell_id"], "portal other_cell_id"),
                int(p.get("other_portal_id", 0xFFFF)),
            )
            for p in ec.get("cell_portals", [])
        ]
        for p in portals:
            if p.polygon_id not in cell_struct.polygons:
                raise SceneFormatError(f"env cell {cell_id:08X}: portal polygon {p.polygon_id} is not in its cell struct")
        visible = [hex_id(v, "visible cell") for v in ec.get("visible_cells", [])]
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
        model_id = hex_id(b.get("model_id"), "building model_id")
        frame = frame_from_dict(b.get("frame", {}))
        cell_id = outdoor_cell_id(landblock.id, frame.origin.x, frame.origin.y)
        parts = cache.parts(model_id, Position(cell_id, frame))
        doors = [
            BldPortal(
                int(p.get("flags", 0)),
                hex_id(p["other_cell_id"], "building portal other_cell_id"),
                int(p.get("other_portal_id", 0)),
                tuple(hex_id(s, "stab") for s in p.get("stab_list", [])),
            )
            for p in b.get("portals", [])
        ]
        building = BuildingObj(model_id, parts, doors, int(b.get("num_leaves", 0)))
        land_cell = landblock.cells[(cell_id & 0xFFFF) - 1]
        building.cell = land_cell
        land_cell.building = building
        landblock.buildings.append(building)

    if lb_data.get("objects") or any(ec.get("static_objects") for ec in lb_data.get("env_cells", [])):
        attach_static_objects(landblock, lb_data, cache)
