"""Small shared dat structures and the scene format's id spellings.

Frame, Sphere, Plane, CylSphere, CVertexArray and Polygon as the client
packs them, each turned into the `acphys-scene/1` dict of the same name
(see shared/formats/README.md).
"""

from __future__ import annotations

from typing import Any

from .binary import RecordReader

__all__ = [
    "dat_id_hex",
    "cell_hex",
    "landblock_hex",
    "read_frame",
    "read_sphere",
    "read_plane",
    "read_cyl_sphere",
    "read_vertex_array",
    "read_polygon",
    "read_polygon_table",
    "VERTEX_TYPE_SW",
    "CULL_CLOCKWISE",
    "STIPPLING_NO_POS",
    "STIPPLING_NO_NEG",
]

VERTEX_TYPE_SW = 1  # the only CVertexArray type the client ships (CSWVertex)
CULL_CLOCKWISE = 2  # sides_type whose polygons carry a second (negative side) UV list
STIPPLING_NO_POS = 0x4
STIPPLING_NO_NEG = 0x8

# Smallest byte sizes of repeated items, to reject impossible counts early.
_MIN_VERTEX = 2 + 2 + 24
_MIN_POLYGON = 2 + 10


def dat_id_hex(value: int) -> str:
    """A dat id as the scene format writes it: 8 uppercase hex digits."""
    return f"{value & 0xFFFFFFFF:08X}"


def cell_hex(value: int) -> str:
    """A 16-bit cell id inside a landblock: 4 uppercase hex digits ("FFFF" = outside)."""
    return f"{value & 0xFFFF:04X}"


def landblock_hex(lb_id: int) -> str:
    """A landblock id XXYY: 4 uppercase hex digits."""
    return f"{lb_id & 0xFFFF:04X}"


def read_frame(r: RecordReader, what: str = "frame") -> dict[str, Any]:
    """Frame: origin (3 floats) then the quaternion stored w, x, y, z."""
    return {"origin": r.vec3(f"{what} origin"), "orientation": r.vec4(f"{what} orientation")}


def read_sphere(r: RecordReader, what: str = "sphere") -> dict[str, Any]:
    """Sphere: origin (3 floats), radius."""
    return {"origin": r.vec3(f"{what} origin"), "radius": r.f32(f"{what} radius")}


def read_plane(r: RecordReader, what: str = "plane") -> dict[str, Any]:
    """Plane: normal (3 floats), d, with dot(n, p) + d = 0."""
    return {"normal": r.vec3(f"{what} normal"), "d": r.f32(f"{what} d")}


def read_cyl_sphere(r: RecordReader) -> dict[str, Any]:
    """CylSphere: low point (3 floats), radius, height."""
    return {"origin": r.vec3("cylsphere origin"), "radius": r.f32("cylsphere radius"),
            "height": r.f32("cylsphere height")}  # fmt: skip


def read_vertex_array(r: RecordReader) -> dict[str, list[float]]:
    """CVertexArray: vertex type (int, 1 = SWVertex), count, then per vertex its
    ushort id, ushort UV count, position, normal and UV pairs.

    Only positions are kept (physics never reads normals or UVs); keys are the
    vertex ids as decimal strings.
    """
    vertex_type = r.i32("vertex type")
    if vertex_type != VERTEX_TYPE_SW:
        raise r.error(f"vertex array of type {vertex_type}; only type {VERTEX_TYPE_SW} (SWVertex) exists")
    count = r.count(r.u32("vertex count"), _MIN_VERTEX, "vertex")
    vertices: dict[str, list[float]] = {}
    for _ in range(count):
        key = r.u16("vertex id")
        num_uvs = r.u16("vertex UV count")
        vertices[str(key)] = r.vec3("vertex position")
        r.skip(12 + 8 * num_uvs, "vertex normal and UVs")
    return vertices


def read_polygon(r: RecordReader) -> dict[str, Any]:
    """Polygon: point count (byte), stippling (byte), sides type (int), positive and
    negative surface (shorts), vertex ids (shorts), then UV index bytes: one list
    unless stippling has NoPos, a second when sides type is 2 (clockwise) and
    stippling lacks NoNeg. UV indices are dropped.
    """
    num_pts = r.u8("polygon point count")
    stippling = r.u8("polygon stippling")
    sides_type = r.i32("polygon sides type")
    pos_surface = r.i16("polygon positive surface")
    neg_surface = r.i16("polygon negative surface")
    vertex_ids = list(r.array("h", num_pts, "polygon vertex ids"))
    if not stippling & STIPPLING_NO_POS:
        r.skip(num_pts, "polygon positive UV indices")
    if sides_type == CULL_CLOCKWISE and not stippling & STIPPLING_NO_NEG:
        r.skip(num_pts, "polygon negative UV indices")
    return {
        "vertex_ids": vertex_ids,
        "sides_type": sides_type,
        "stippling": stippling,
        "pos_surface": pos_surface,
        "neg_surface": neg_surface,
    }


def read_polygon_table(r: RecordReader, count: int, what: str = "polygon") -> dict[str, dict[str, Any]]:
    """`count` pairs of (ushort polygon id, Polygon), keyed by the id as a decimal string."""
    r.count(count, _MIN_POLYGON, what)
    table: dict[str, dict[str, Any]] = {}
    for _ in range(count):
        key = r.u16(f"{what} id")
        table[str(key)] = read_polygon(r)
    return table
