"""Records of the cell dat (`client_cell_1.dat`).

* CellLandblock `0xXXYYFFFF`: the landblock's terrain words and height bytes.
* LandblockInfo `0xXXYYFFFE`: EnvCell count, static objects, buildings (with
  their portals into EnvCells) and an optional restriction table.
* EnvCell `0xXXYY0100` and up: one indoor cell.

Each parser takes the record's bytes and returns the `acphys-scene/1` pieces
(or a small dataclass holding them); `path` and `file_id` only label errors.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from .binary import RecordReader
from .shapes import cell_hex, dat_id_hex, read_frame

__all__ = [
    "CellLandblock",
    "LandblockInfo",
    "parse_cell_landblock",
    "parse_landblock_info",
    "parse_env_cell",
    "ENV_CELL_SEEN_OUTSIDE",
    "ENV_CELL_HAS_STATIC_OBJS",
    "ENV_CELL_HAS_RESTRICTION_OBJ",
    "VERTICES_PER_LANDBLOCK",
]

VERTICES_PER_LANDBLOCK = 81  # 9 x 9, index x * 9 + y
ENV_CELL_SEEN_OUTSIDE = 0x1
ENV_CELL_HAS_STATIC_OBJS = 0x2
ENV_CELL_HAS_RESTRICTION_OBJ = 0x8
_LBI_HAS_RESTRICTIONS = 0x1
_MIN_STAB = 4 + 28
_MIN_BUILDING = 4 + 28 + 4 + 4
_MIN_BUILDING_PORTAL = 8


@dataclass(slots=True)
class CellLandblock:
    """A CellLandblock record: `terrain` words and `heights` bytes, 81 each (index x * 9 + y)."""

    id: int
    has_objects: bool
    terrain: list[int]
    heights: list[int]


@dataclass(slots=True)
class LandblockInfo:
    """A LandblockInfo record; `objects` and `buildings` are already scene-format dicts."""

    id: int
    num_cells: int
    objects: list[dict[str, Any]] = field(default_factory=list)
    buildings: list[dict[str, Any]] = field(default_factory=list)
    restriction_table: dict[int, int] = field(default_factory=dict)


def parse_cell_landblock(data: bytes, *, path: str | None = None, file_id: int | None = None) -> CellLandblock:
    """CellLandblock: id (uint), has-objects (uint, 1 = true), 81 terrain ushorts,
    81 height bytes, padding to 4 bytes."""
    r = RecordReader(data, path, file_id, "CellLandblock")
    lb_id = r.u32("id")
    r.check_own_id(lb_id)
    has_objects = r.u32("has-objects flag") == 1
    terrain = list(r.array("H", VERTICES_PER_LANDBLOCK, "terrain words"))
    heights = list(r.array("B", VERTICES_PER_LANDBLOCK, "height bytes"))
    r.align4()
    return CellLandblock(lb_id, has_objects, terrain, heights)


def _read_stabs(r: RecordReader, what: str) -> list[dict[str, Any]]:
    """A uint count of Stabs: object id (uint) and frame each."""
    count = r.count(r.u32(f"{what} count"), _MIN_STAB, what)
    return [{"id": dat_id_hex(r.u32(f"{what} id")), "frame": read_frame(r, what)} for _ in range(count)]


def _read_building_portal(r: RecordReader) -> dict[str, Any]:
    """CBldPortal: flags, other cell, other portal, stab count (ushorts), stab list, padding."""
    flags = r.u16("building portal flags")
    other_cell = r.u16("building portal other cell")
    other_portal = r.u16("building portal other portal")
    num_stabs = r.count(r.u16("building portal stab count"), 2, "building portal stab")
    stabs = [cell_hex(c) for c in r.array("H", num_stabs, "building portal stab list")]
    r.align4()
    return {"flags": flags, "other_cell_id": cell_hex(other_cell), "other_portal_id": other_portal,
            "stab_list": stabs}  # fmt: skip


def _read_building(r: RecordReader) -> dict[str, Any]:
    """BuildInfo: model id, frame, leaf count, then a uint count of CBldPortals."""
    model_id = r.u32("building model id")
    frame = read_frame(r, "building frame")
    num_leaves = r.u32("building leaf count")
    num_portals = r.count(r.u32("building portal count"), _MIN_BUILDING_PORTAL, "building portal")
    portals = [_read_building_portal(r) for _ in range(num_portals)]
    return {"model_id": dat_id_hex(model_id), "frame": frame, "num_leaves": num_leaves, "portals": portals}


def parse_landblock_info(data: bytes, *, path: str | None = None, file_id: int | None = None) -> LandblockInfo:
    """LandblockInfo: id, EnvCell count (uints), Stab list of static objects,
    building count and pack mask (ushorts), the buildings, and when the mask
    has bit 0 a restriction table (ushort count, ushort bucket count, then
    (uint, uint) pairs)."""
    r = RecordReader(data, path, file_id, "LandblockInfo")
    lbi_id = r.u32("id")
    r.check_own_id(lbi_id)
    num_cells = r.u32("EnvCell count")
    objects = _read_stabs(r, "static object")
    num_buildings = r.count(r.u16("building count"), _MIN_BUILDING, "building")
    pack_mask = r.u16("pack mask")
    buildings = [_read_building(r) for _ in range(num_buildings)]
    restrictions: dict[int, int] = {}
    if pack_mask & _LBI_HAS_RESTRICTIONS:
        count = r.count(r.u16("restriction table count"), 8, "restriction table entry")
        r.u16("restriction table bucket count")
        pairs = r.array("I", 2 * count, "restriction table entries")
        restrictions = dict(zip(pairs[0::2], pairs[1::2]))
    return LandblockInfo(lbi_id, num_cells, objects, buildings, restrictions)


def parse_env_cell(data: bytes, *, path: str | None = None, file_id: int | None = None) -> dict[str, Any]:
    """EnvCell: id, flags, id again (uints); surface, portal (bytes) and stab
    (ushort) counts; surface ids (ushorts, dropped); environment id and cell
    structure index (ushorts); frame; CellPortals (four ushorts: flags,
    polygon, other cell, other portal); visible cell ids (ushorts); static
    objects (Stab list) when flags has 0x2; restriction object (uint) when
    flags has 0x8. Returns the scene format's EnvCell dict.
    """
    r = RecordReader(data, path, file_id, "EnvCell")
    cell_id = r.u32("id")
    r.check_own_id(cell_id)
    flags = r.u32("flags")
    r.u32("repeated cell id")
    num_surfaces = r.u8("surface count")
    num_portals = r.u8("portal count")
    num_stabs = r.u16("visible cell count")
    r.skip(2 * num_surfaces, "surface ids")
    environment_id = 0x0D000000 | r.u16("environment id")
    cell_structure = r.u16("cell structure index")
    position = read_frame(r, "cell frame")
    portals = []
    for _ in range(num_portals):
        p_flags, polygon, other_cell, other_portal = r.array("H", 4, "cell portal")
        portals.append({"flags": p_flags, "polygon_id": polygon, "other_cell_id": cell_hex(other_cell),
                        "other_portal_id": other_portal})  # fmt: skip
    visible = [cell_hex(c) for c in r.array("H", num_stabs, "visible cell ids")]
    static_objects = _read_stabs(r, "static object") if flags & ENV_CELL_HAS_STATIC_OBJS else []
    restriction_obj = r.u32("restriction object") if flags & ENV_CELL_HAS_RESTRICTION_OBJ else 0
    return {
        "id": dat_id_hex(cell_id),
        "environment_id": dat_id_hex(environment_id),
        "cell_structure": cell_structure,
        "position": position,
        "cell_portals": portals,
        "visible_cells": visible,
        "seen_outside": bool(flags & ENV_CELL_SEEN_OUTSIDE),
        "static_objects": static_objects,
        "restriction_obj": restriction_obj,
    }
