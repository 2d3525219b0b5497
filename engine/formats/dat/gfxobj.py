"""GfxObj records (`0x01......` in the portal dat): one rigid part's geometry."""

from __future__ import annotations

from typing import Any

from .binary import RecordReader
from .bsp import count_leaves, read_bsp
from .shapes import read_polygon_table, read_vertex_array

__all__ = ["parse_gfx_obj", "GFXOBJ_HAS_PHYSICS", "GFXOBJ_HAS_DRAWING", "GFXOBJ_HAS_DEGRADE"]

GFXOBJ_HAS_PHYSICS = 0x1
GFXOBJ_HAS_DRAWING = 0x2
GFXOBJ_HAS_DEGRADE = 0x8


def parse_gfx_obj(data: bytes, *, path: str | None = None, file_id: int | None = None) -> dict[str, Any]:
    """GfxObj: id, flags (uints); surface ids (packed count, uints; dropped);
    CVertexArray; with flag 0x1 the physics polygons (packed count, ushort id +
    Polygon each) and the physics BSP; the sort center (3 floats); then drawing
    polygons, drawing BSP and degrade id, which physics never reads and which
    are not parsed.

    Returns the scene format's GfxObj: `vertices`, `physics_polygons`,
    `physics_bsp` and `num_physics_leaves` (only with physics), `sort_center`.
    """
    r = RecordReader(data, path, file_id, "GfxObj")
    r.own_id()
    flags = r.u32("flags")
    num_surfaces = r.count(r.compressed_u32("surface count"), 4, "surface")
    r.skip(4 * num_surfaces, "surface ids")
    out: dict[str, Any] = {"vertices": read_vertex_array(r)}
    if flags & GFXOBJ_HAS_PHYSICS:
        out["physics_polygons"] = read_polygon_table(r, r.compressed_u32("physics polygon count"), "physics polygon")
        out["physics_bsp"] = read_bsp(r, "physics")
        out["num_physics_leaves"] = count_leaves(out["physics_bsp"])
    out["sort_center"] = r.vec3("sort center")
    return out
