"""Environment records (`0x0D......` in the portal dat) and their CellStructs."""

from __future__ import annotations

from typing import Any

from .binary import RecordReader
from .bsp import read_bsp
from .shapes import read_polygon_table, read_vertex_array

__all__ = ["parse_environment", "read_cell_struct"]

_MIN_CELL_STRUCT = 12 + 8  # three counts and an empty vertex array


def read_cell_struct(r: RecordReader) -> dict[str, Any]:
    """CellStruct: polygon, physics polygon and portal counts (uints); the
    CVertexArray; the polygons (ushort id + Polygon each); portal polygon ids
    (ushorts); padding to 4; the cell BSP; the physics polygons; the physics
    BSP; a uint "has drawing BSP" and that drawing BSP (skipped); padding.

    Returns the scene format's CellStruct (drawing BSP left out).
    """
    num_polygons = r.u32("polygon count")
    num_physics_polygons = r.u32("physics polygon count")
    num_portals = r.u32("portal count")
    vertices = read_vertex_array(r)
    polygons = read_polygon_table(r, num_polygons, "polygon")
    r.count(num_portals, 2, "portal")
    portals = list(r.array("H", num_portals, "portal polygon ids"))
    r.align4()
    cell_bsp = read_bsp(r, "cell")
    physics_polygons = read_polygon_table(r, num_physics_polygons, "physics polygon")
    physics_bsp = read_bsp(r, "physics")
    if r.u32("has-drawing-BSP flag"):
        read_bsp(r, "drawing")  # only to step over it: physics never draws
    r.align4()
    return {
        "vertices": vertices,
        "polygons": polygons,
        "portals": portals,
        "cell_bsp": cell_bsp,
        "physics_polygons": physics_polygons,
        "physics_bsp": physics_bsp,
    }


def parse_environment(data: bytes, *, path: str | None = None, file_id: int | None = None) -> dict[str, Any]:
    """Environment: id, CellStruct count (uints), then (uint index, CellStruct) pairs.

    Returns `{"cell_structs": {"<index>": CellStruct, ...}}`.
    """
    r = RecordReader(data, path, file_id, "Environment")
    r.own_id()
    count = r.count(r.u32("cell struct count"), _MIN_CELL_STRUCT, "cell struct")
    structs: dict[str, dict[str, Any]] = {}
    for _ in range(count):
        index = r.u32("cell struct index")
        r.record = f"Environment cell struct {index}"
        structs[str(index)] = read_cell_struct(r)
        r.record = "Environment"
    return {"cell_structs": structs}
