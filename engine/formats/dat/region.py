"""The Region record (`0x13000000` in the portal dat): world-wide terrain constants.

Terrain needs only the LandDefs block near the start (grid sizes and the
LandHeightTable). Everything after it (game time, sky, sound, scenes, terrain
textures, misc) is left unread, so differences there cannot break loading.
"""

from __future__ import annotations

from dataclasses import dataclass

from .binary import RecordReader

__all__ = ["REGION_ID", "RegionInfo", "parse_region"]

REGION_ID = 0x13000000
HEIGHT_TABLE_SIZE = 256


@dataclass(slots=True)
class RegionInfo:
    """The Region's header and LandDefs."""

    id: int
    region_number: int
    version: int
    name: str
    num_block_length: int
    num_block_width: int
    square_length: float
    lblock_length: int
    vertex_per_cell: int
    max_obj_height: float
    sky_height: float
    road_width: float
    height_table: list[float]


def parse_region(data: bytes, *, path: str | None = None, file_id: int | None = REGION_ID) -> RegionInfo:
    """Region: id, region number, version (uints); name (ushort length, or
    0xFFFF then a uint length, then bytes); padding to 4; LandDefs: block
    length and width (ints), square length (float), landblock length and
    vertices per cell (ints), max object height, sky height, road width
    (floats), 256 float LandHeightTable entries. The rest is not read.
    """
    r = RecordReader(data, path, file_id, "Region")
    region_id = r.own_id()
    number = r.u32("region number")
    version = r.u32("version")
    length = r.u16("name length")
    if length == 0xFFFF:
        length = r.u32("long name length")
    name = r.raw(length, "name").decode("latin-1")
    r.align4()
    return RegionInfo(
        id=region_id,
        region_number=number,
        version=version,
        name=name,
        num_block_length=r.i32("NumBlockLength"),
        num_block_width=r.i32("NumBlockWidth"),
        square_length=r.f32("SquareLength"),
        lblock_length=r.i32("LBlockLength"),
        vertex_per_cell=r.i32("VertexPerCell"),
        max_obj_height=r.f32("MaxObjHeight"),
        sky_height=r.f32("SkyHeight"),
        road_width=r.f32("RoadWidth"),
        height_table=list(r.array("f", HEIGHT_TABLE_SIZE, "LandHeightTable")),
    )
