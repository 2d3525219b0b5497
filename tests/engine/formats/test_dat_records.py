"""Each record parser on byte strings built field by field from the format description.

Expected values are written out by hand here, not produced by the parser.
Floats are chosen to be exact in float32 so they compare with ==.
"""

from __future__ import annotations

import pytest

from engine.formats.dat import (
    CellLandblock,
    DatError,
    parse_cell_landblock,
    parse_env_cell,
    parse_environment,
    parse_gfx_obj,
    parse_landblock_info,
    parse_region,
    parse_setup,
    read_bsp,
)
from engine.formats.dat.binary import RecordReader
from engine.formats.dat.shapes import read_polygon, read_vertex_array
from support.datwriter import Packer

IDENTITY = [1.0, 0.0, 0.0, 0.0]
HALF = [0.5, 0.5, 0.5, 0.5]
SENTINEL = 0xC0FFEE11


def reader(p: Packer) -> RecordReader:
    return RecordReader(p.getvalue(), "test.dat", 0x01020304, "test record")


# -- primitives ------------------------------------------------------------------------


def test_compressed_counts_and_packed_ids() -> None:
    r = RecordReader(bytes([0x7F, 0x81, 0x02, 0xC1, 0x02, 0x04, 0x03, 0x05, 0x00, 0x01, 0x80, 0x02, 0x00]))
    assert r.compressed_u32() == 0x7F
    assert r.compressed_u32() == 0x0102
    assert r.compressed_u32() == 0x01020304
    assert r.packed_data_id(0x01000000) == 0x01000005
    assert r.packed_data_id(0x01000000) == 0x01010002
    assert r.at_end()


def test_tags_are_stored_reversed() -> None:
    r = RecordReader(b"NnPBFAEL")
    assert r.tag() == "BPnN"
    assert r.tag() == "LEAF"


def test_short_record_names_field_file_and_path() -> None:
    r = RecordReader(b"\x01\x02", "x.dat", 0x0D000001, "Environment")
    with pytest.raises(DatError) as info:
        r.u32("cell struct count")
    msg = str(info.value)
    assert "x.dat" in msg and "0x0D000001" in msg and "cell struct count" in msg and "truncated" in msg


def test_vertex_array_keeps_positions_only() -> None:
    p = Packer().i32(1).u32(2)
    p.u16(4).u16(2).vec3([1.0, 2.0, 3.0]).vec3([0.0, 0.0, 1.0]).f32(0.1).f32(0.2).f32(0.3).f32(0.4)
    p.u16(9).u16(0).vec3([-1.5, 0.25, 8.0]).vec3([1.0, 0.0, 0.0])
    p.u32(SENTINEL)
    r = reader(p)
    assert read_vertex_array(r) == {"4": [1.0, 2.0, 3.0], "9": [-1.5, 0.25, 8.0]}
    assert r.u32() == SENTINEL


def test_vertex_array_of_unknown_type() -> None:
    with pytest.raises(DatError, match="type 2"):
        read_vertex_array(reader(Packer().i32(2).u32(0)))


@pytest.mark.parametrize(
    "stippling,sides,uv_lists",
    [(0, 0, 1), (0, 1, 1), (0, 2, 2), (0x4, 2, 1), (0x8, 2, 1), (0x4 | 0x8, 2, 0), (0x4, 0, 0)],
)
def test_polygon_uv_lists(stippling: int, sides: int, uv_lists: int) -> None:
    p = Packer().u8(3).u8(stippling).i32(sides).i16(7).i16(-1).i16(2).i16(0).i16(5)
    p.raw(b"\x00\x01\x02" * uv_lists).u32(SENTINEL)
    r = reader(p)
    assert read_polygon(r) == {"vertex_ids": [2, 0, 5], "sides_type": sides, "stippling": stippling,
                               "pos_surface": 7, "neg_surface": -1}  # fmt: skip
    assert r.u32() == SENTINEL


# -- BSP trees --------------------------------------------------------------------------


def test_physics_bsp() -> None:
    p = Packer().tag("BPIN").plane([0.0, 0.0, 1.0], -2.0)
    p.tag("LEAF").i32(0).i32(0).sphere([0.0, 0.0, 3.0], 1.5).u32(0)
    p.tag("BpnN").plane([1.0, 0.0, 0.0], 0.5)
    p.tag("LEAF").i32(1).i32(1).sphere([0.0, 0.0, 1.0], 2.5).u32(2).u16(0).u16(2)
    p.sphere([0.25, 0.0, 1.0], 2.75)  # BpnN's sphere, after its child
    p.sphere([0.0, 0.0, 1.5], 4.0)  # root sphere
    p.u32(SENTINEL)
    r = reader(p)
    assert read_bsp(r, "physics") == {
        "type": "BPIN",
        "splitting_plane": {"normal": [0.0, 0.0, 1.0], "d": -2.0},
        "pos_node": {"type": "LEAF", "leaf_index": 0, "solid": 0,
                     "sphere": {"origin": [0.0, 0.0, 3.0], "radius": 1.5}, "in_polys": []},
        "neg_node": {
            "type": "BpnN",
            "splitting_plane": {"normal": [1.0, 0.0, 0.0], "d": 0.5},
            "neg_node": {"type": "LEAF", "leaf_index": 1, "solid": 1,
                         "sphere": {"origin": [0.0, 0.0, 1.0], "radius": 2.5}, "in_polys": [0, 2]},
            "sphere": {"origin": [0.25, 0.0, 1.0], "radius": 2.75},
        },
        "sphere": {"origin": [0.0, 0.0, 1.5], "radius": 4.0},
    }  # fmt: skip
    assert r.u32() == SENTINEL


def test_cell_bsp_children_follow_the_tag() -> None:
    p = Packer().tag("BPnn").plane([0.0, 0.0, 1.0], 0.0)
    p.tag("BpIN").plane([-1.0, 0.0, 0.0], 3.75)
    p.tag("BPnN").plane([0.0, 1.0, 0.0], 2.0)
    p.tag("LEAF").i32(0)
    p.tag("LEAF").i32(1)
    p.u32(SENTINEL)
    r = reader(p)
    assert read_bsp(r, "cell") == {
        "type": "BPnn",
        "splitting_plane": {"normal": [0.0, 0.0, 1.0], "d": 0.0},
        "pos_node": {
            "type": "BpIN",
            "splitting_plane": {"normal": [-1.0, 0.0, 0.0], "d": 3.75},
            "neg_node": {
                "type": "BPnN",
                "splitting_plane": {"normal": [0.0, 1.0, 0.0], "d": 2.0},
                "pos_node": {"type": "LEAF", "leaf_index": 0},
                "neg_node": {"type": "LEAF", "leaf_index": 1},
            },
        },
    }
    assert r.u32() == SENTINEL


def test_drawing_bsp_is_stepped_over() -> None:
    p = Packer().tag("BPIn").plane([1.0, 0.0, 0.0], 0.0)
    p.tag("PORT").plane([0.0, 1.0, 0.0], 1.0)
    p.tag("LEAF").i32(0)
    p.tag("LEAF").i32(1)
    p.sphere([0.0, 0.0, 0.0], 1.0).u32(3).u32(2).u16(1).u16(2).u16(3).i16(0).i16(4).i16(1).i16(5)
    p.sphere([0.0, 0.0, 0.0], 2.0).u32(1).u16(9)
    p.u32(SENTINEL)
    r = reader(p)
    tree = read_bsp(r, "drawing")
    assert tree["pos_node"]["in_portals"] == [[0, 4], [1, 5]]
    assert tree["in_polys"] == [9]
    assert r.u32() == SENTINEL


def test_unknown_bsp_tag() -> None:
    with pytest.raises(DatError, match="unknown BSP node tag 'ABCD'"):
        read_bsp(reader(Packer().tag("ABCD")), "physics")


# -- cell dat records ---------------------------------------------------------------------


def test_cell_landblock() -> None:
    terrain = [(i % 32) << 2 | (i % 3) for i in range(81)]  # type bits 2..6, road bits 0..1
    heights = [(7 * i) % 256 for i in range(81)]
    p = Packer().u32(0xA9B4FFFF).u32(1)
    for t in terrain:
        p.u16(t)
    for h in heights:
        p.u8(h)
    p.align4()
    assert len(p) == 252
    assert parse_cell_landblock(p.getvalue(), file_id=0xA9B4FFFF) == CellLandblock(0xA9B4FFFF, True, terrain, heights)
    # Without the final pad byte it still reads; has-objects 0 is False.
    bare = Packer().u32(0x0101FFFF).u32(0).raw(b"\0" * 162).raw(bytes(range(81)))
    lb = parse_cell_landblock(bare.getvalue())
    assert (lb.id, lb.has_objects, lb.heights[80], lb.terrain[0]) == (0x0101FFFF, False, 80, 0)


def test_cell_landblock_with_the_wrong_id() -> None:
    p = Packer().u32(0x1111FFFF).u32(0).raw(b"\0" * 244)
    with pytest.raises(DatError, match="0x1111FFFF, not its own id"):
        parse_cell_landblock(p.getvalue(), path="c.dat", file_id=0x2222FFFF)


def test_landblock_info() -> None:
    p = Packer().u32(0x1234FFFE).u32(2)
    p.u32(1).u32(0x01000005).frame([1.0, 2.0, 3.0], HALF)  # one static object
    p.u16(1).u16(1)  # one building; pack mask: has restriction table
    p.u32(0x01000001).frame([96.0, 48.0, 10.5], IDENTITY).u32(7).u32(2)
    p.u16(2).u16(0x0100).u16(0).u16(3).u16(0x0100).u16(0x0101).u16(0x0102).align4()
    p.u16(1).u16(0x0101).u16(1).u16(1).u16(0x0101).align4()
    p.u16(1).u16(8).u32(0x12340100).u32(0x7ABCDEF0)
    info = parse_landblock_info(p.getvalue(), file_id=0x1234FFFE)
    assert (info.id, info.num_cells) == (0x1234FFFE, 2)
    assert info.objects == [{"id": "01000005", "frame": {"origin": [1.0, 2.0, 3.0], "orientation": HALF}}]
    assert info.buildings == [{
        "model_id": "01000001",
        "frame": {"origin": [96.0, 48.0, 10.5], "orientation": IDENTITY},
        "num_leaves": 7,
        "portals": [
            {"flags": 2, "other_cell_id": "0100", "other_portal_id": 0, "stab_list": ["0100", "0101", "0102"]},
            {"flags": 1, "other_cell_id": "0101", "other_portal_id": 1, "stab_list": ["0101"]},
        ],
    }]  # fmt: skip
    assert info.restriction_table == {0x12340100: 0x7ABCDEF0}


def test_env_cell_with_everything() -> None:
    p = Packer().u32(0x12340101).u32(0x1 | 0x2 | 0x8).u32(0x12340101)
    p.u8(3).u8(2).u16(3)  # surfaces, portals, visible cells
    p.u16(0x0010).u16(0x0011).u16(0x0012)
    p.u16(0x0042).u16(5).frame([50.0, 60.0, -12.0], HALF)
    p.u16(0).u16(3).u16(0x0100).u16(1)
    p.u16(2).u16(4).u16(0xFFFF).u16(0xFFFF)
    p.u16(0x0100).u16(0x0101).u16(0x0102)
    p.u32(1).u32(0x02000003).frame([51.0, 61.0, -12.0], IDENTITY)
    p.u32(0x7F000123)
    assert parse_env_cell(p.getvalue(), file_id=0x12340101) == {
        "id": "12340101",
        "environment_id": "0D000042",
        "cell_structure": 5,
        "position": {"origin": [50.0, 60.0, -12.0], "orientation": HALF},
        "cell_portals": [
            {"flags": 0, "polygon_id": 3, "other_cell_id": "0100", "other_portal_id": 1},
            {"flags": 2, "polygon_id": 4, "other_cell_id": "FFFF", "other_portal_id": 65535},
        ],
        "visible_cells": ["0100", "0101", "0102"],
        "seen_outside": True,
        "static_objects": [{"id": "02000003", "frame": {"origin": [51.0, 61.0, -12.0], "orientation": IDENTITY}}],
        "restriction_obj": 0x7F000123,
    }


def test_env_cell_minimal() -> None:
    p = Packer().u32(0x12340100).u32(0).u32(0x12340100).u8(0).u8(0).u16(1)
    p.u16(0x0001).u16(0).frame([0.0, 0.0, 0.0], IDENTITY).u16(0x0100)
    cell = parse_env_cell(p.getvalue(), file_id=0x12340100)
    assert (cell["seen_outside"], cell["static_objects"], cell["restriction_obj"]) == (False, [], 0)
    assert (cell["environment_id"], cell["cell_portals"], cell["visible_cells"]) == ("0D000001", [], ["0100"])


# -- portal dat records ---------------------------------------------------------------------


def test_environment_with_one_cell_struct() -> None:
    p = Packer().u32(0x0D000007).u32(1).u32(3)  # id, one struct, its index 3
    p.u32(1).u32(1).u32(1)  # polygons, physics polygons, portals
    p.i32(1).u32(3)
    for key, xyz in ((0, [0.0, 0.0, 0.0]), (1, [4.0, 0.0, 0.0]), (2, [0.0, 4.0, 0.0])):
        p.u16(key).u16(1).vec3(xyz).vec3([0.0, 0.0, 1.0]).f32(0.0).f32(1.0)
    p.u16(6).u8(3).u8(0).i32(0).i16(1).i16(-1).i16(0).i16(1).i16(2).raw(b"\0\1\2")  # drawing polygon 6
    p.u16(6).align4()  # portal list, then padding
    p.tag("LEAF").i32(0)  # cell BSP
    p.u16(1).u8(3).u8(0x4).i32(0).i16(0).i16(-1).i16(2).i16(1).i16(0)  # physics polygon 1, no UVs
    p.tag("LEAF").i32(0).i32(1).sphere([1.0, 1.0, 0.0], 3.0).u32(1).u16(1)  # physics BSP
    p.u32(1).tag("LEAF").i32(0)  # a drawing BSP
    p.align4()
    assert parse_environment(p.getvalue(), file_id=0x0D000007) == {"cell_structs": {"3": {
        "vertices": {"0": [0.0, 0.0, 0.0], "1": [4.0, 0.0, 0.0], "2": [0.0, 4.0, 0.0]},
        "polygons": {"6": {"vertex_ids": [0, 1, 2], "sides_type": 0, "stippling": 0,
                           "pos_surface": 1, "neg_surface": -1}},
        "portals": [6],
        "cell_bsp": {"type": "LEAF", "leaf_index": 0},
        "physics_polygons": {"1": {"vertex_ids": [2, 1, 0], "sides_type": 0, "stippling": 4,
                                   "pos_surface": 0, "neg_surface": -1}},
        "physics_bsp": {"type": "LEAF", "leaf_index": 0, "solid": 1,
                        "sphere": {"origin": [1.0, 1.0, 0.0], "radius": 3.0}, "in_polys": [1]},
    }}}  # fmt: skip


def _gfx_prefix(flags: int) -> Packer:
    p = Packer().u32(0x01000009).u32(flags).u8(2).u32(0x08000001).u32(0x08000002)
    p.i32(1).u32(2)
    p.u16(0).u16(0).vec3([-1.0, -1.0, 0.0]).vec3([0.0, 0.0, 1.0])
    p.u16(1).u16(0).vec3([1.0, 1.0, 2.0]).vec3([0.0, 0.0, 1.0])
    return p


def test_gfx_obj_with_physics() -> None:
    p = _gfx_prefix(0x1 | 0x2 | 0x8)
    p.u8(1).u16(0).u8(3).u8(0).i32(1).i16(3).i16(3).i16(0).i16(1).i16(1).raw(b"\0\0\0")
    p.tag("LEAF").i32(0).i32(1).sphere([0.0, 0.0, 1.0], 1.75).u32(1).u16(0)
    p.vec3([0.0, 0.0, 1.0])
    p.raw(b"drawing polygons and BSP that physics never reads")
    assert parse_gfx_obj(p.getvalue(), file_id=0x01000009) == {
        "vertices": {"0": [-1.0, -1.0, 0.0], "1": [1.0, 1.0, 2.0]},
        "physics_polygons": {"0": {"vertex_ids": [0, 1, 1], "sides_type": 1, "stippling": 0,
                                   "pos_surface": 3, "neg_surface": 3}},
        "physics_bsp": {"type": "LEAF", "leaf_index": 0, "solid": 1,
                        "sphere": {"origin": [0.0, 0.0, 1.0], "radius": 1.75}, "in_polys": [0]},
        "num_physics_leaves": 1,
        "sort_center": [0.0, 0.0, 1.0],
    }  # fmt: skip


def test_gfx_obj_drawing_only() -> None:
    p = _gfx_prefix(0x2).vec3([0.5, 0.5, 0.5]).raw(b"\x01\x02")
    assert parse_gfx_obj(p.getvalue()) == {
        "vertices": {"0": [-1.0, -1.0, 0.0], "1": [1.0, 1.0, 2.0]},
        "sort_center": [0.5, 0.5, 0.5],
    }


def _setup_bytes(hooks: Packer) -> Packer:
    p = Packer().u32(0x02000009).u32(0x1 | 0x2 | 0x4).u32(2).u32(0x01000001).u32(0x01000002)
    p.u32(0xFFFFFFFF).u32(0)  # parent indices
    p.vec3([1.0, 1.0, 1.0]).vec3([2.0, 2.0, 0.5])  # default scales
    p.i32(1).i32(1).i32(0).frame([0.0, 0.0, 1.0], IDENTITY)  # holding location
    p.i32(1).i32(2).i32(1).frame([0.0, 1.0, 0.0], IDENTITY)  # connection point
    p.i32(2)
    p.i32(0).frame([0.0, 0.0, 0.0], IDENTITY).frame([0.0, 0.0, 1.0], HALF).u32(0)
    p.i32(0x65).frame([1.0, 0.0, 0.0], IDENTITY).frame([1.0, 0.0, 1.0], IDENTITY).raw(hooks.getvalue())
    p.u32(1).vec3([0.0, 0.0, 0.0]).f32(0.5).f32(1.75)  # cylsphere
    p.u32(2).sphere([0.0, 0.0, 0.5], 0.5).sphere([0.0, 0.0, 1.25], 0.5)
    p.f32(1.75).f32(0.625).f32(0.5).f32(0.25)  # height, radius, step up, step down
    p.sphere([0.0, 0.0, 0.75], 1.0).sphere([0.0, 0.0, 0.875], 1.25)
    p.i32(1).i32(0).frame([0.0, 0.0, 2.0], IDENTITY).u32(0xFFFFFFFF).f32(1.0).f32(4.0).f32(0.0)  # a light
    p.u32(0x03000001).u32(0).u32(0x09000001).u32(0x20000001).u32(0x34000001)
    return p


def test_setup() -> None:
    hooks = Packer().u32(4)
    hooks.u32(1).i32(0).u32(0x0A000001)  # Sound
    hooks.u32(5).i32(1).u16(0).u16(0x0007)  # ReplaceObject with a 2-byte packed id
    hooks.u32(3).i32(0).u32(0).f32(0.0).f32(1.0).f32(1.0).f32(0.0).f32(2.0).f32(1.0)  # Attack
    hooks.u32(13).i32(0).u32(0x32000001).u32(0).frame([0.0, 0.0, 0.0], IDENTITY).u32(9)  # CreateParticle
    assert parse_setup(_setup_bytes(hooks).getvalue(), file_id=0x02000009) == {
        "parts": ["01000001", "01000002"],
        "placement_frames": {
            "0": {"frames": [{"origin": [0.0, 0.0, 0.0], "orientation": IDENTITY},
                             {"origin": [0.0, 0.0, 1.0], "orientation": HALF}]},
            "101": {"frames": [{"origin": [1.0, 0.0, 0.0], "orientation": IDENTITY},
                               {"origin": [1.0, 0.0, 1.0], "orientation": IDENTITY}]},
        },
        "default_scale": [[1.0, 1.0, 1.0], [2.0, 2.0, 0.5]],
        "spheres": [{"origin": [0.0, 0.0, 0.5], "radius": 0.5}, {"origin": [0.0, 0.0, 1.25], "radius": 0.5}],
        "cyl_spheres": [{"origin": [0.0, 0.0, 0.0], "radius": 0.5, "height": 1.75}],
        "height": 1.75,
        "radius": 0.625,
        "step_up_height": 0.5,
        "step_down_height": 0.25,
        "sorting_sphere": {"origin": [0.0, 0.0, 0.75], "radius": 1.0},
        "selection_sphere": {"origin": [0.0, 0.0, 0.875], "radius": 1.25},
        "allow_free_heading": True,
    }  # fmt: skip


def test_setup_with_an_unknown_hook() -> None:
    hooks = Packer().u32(1).u32(99).i32(0)
    with pytest.raises(DatError, match="unknown animation hook type 99"):
        parse_setup(_setup_bytes(hooks).getvalue(), path="p.dat", file_id=0x02000009)


def test_region_reads_the_height_table_and_stops() -> None:
    p = Packer().u32(0x13000000).u32(1).u32(4).u16(3).raw(b"Abc").align4()
    assert len(p) == 20
    p.i32(255).i32(254).f32(24.0).i32(8).i32(1).f32(200.0).f32(1000.0).f32(5.0)
    for i in range(256):
        p.f32(i * 0.5)
    p.raw(b"\xde\xad")  # whatever follows is not read
    region = parse_region(p.getvalue())
    assert (region.id, region.region_number, region.version, region.name) == (0x13000000, 1, 4, "Abc")
    assert (region.num_block_length, region.num_block_width, region.square_length) == (255, 254, 24.0)
    assert (region.lblock_length, region.vertex_per_cell) == (8, 1)
    assert (region.max_obj_height, region.sky_height, region.road_width) == (200.0, 1000.0, 5.0)
    assert region.height_table == [i * 0.5 for i in range(256)]
