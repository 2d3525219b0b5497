"""Test-only encoders: `acphys-scene/1` pieces -> dat records, and whole scenes -> dat pairs.

Each encoder writes the record field by field in the published order
(Asheron's Call client / ACE DatLoader layouts). Data the scene format does
not keep (UVs, normals, surfaces, drawing BSPs, holding locations, lights,
animation hooks) is filled with plausible values so the reader must step over
it correctly.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .datwriter import DATA_SET_CELL, DATA_SET_PORTAL, Packer, write_dat

REGION_ID = 0x13000000
ITERATION_ID = 0xFFFF0001
ZERO_SPHERE = {"origin": [0.0, 0.0, 0.0], "radius": 0.0}


def put_frame(p: Packer, frame: dict[str, Any]) -> None:
    p.frame(frame["origin"], frame["orientation"])


def put_sphere(p: Packer, sphere: dict[str, Any]) -> None:
    p.sphere(sphere["origin"], sphere["radius"])


def put_vertices(p: Packer, vertices: dict[str, list[float]]) -> None:
    """CVertexArray of SWVertex: each with one UV pair and an up normal."""
    p.i32(1).u32(len(vertices))
    for key, xyz in vertices.items():
        p.u16(int(key)).u16(1).vec3(xyz).vec3([0.0, 0.0, 1.0]).f32(0.5).f32(0.25)


def put_polygon(p: Packer, poly: dict[str, Any]) -> None:
    ids = poly["vertex_ids"]
    stippling = poly.get("stippling", 0)
    sides = poly.get("sides_type", 0)
    p.u8(len(ids)).u8(stippling).i32(sides).i16(poly.get("pos_surface", 0)).i16(poly.get("neg_surface", -1))
    for v in ids:
        p.i16(v)
    if not stippling & 0x4:
        p.raw(bytes(range(len(ids))))  # positive-side UV indices
    if sides == 2 and not stippling & 0x8:
        p.raw(bytes(range(len(ids))))  # negative-side UV indices


def put_polygons(p: Packer, polygons: dict[str, dict[str, Any]]) -> None:
    for key, poly in polygons.items():
        p.u16(int(key))
        put_polygon(p, poly)


def put_bsp(p: Packer, node: dict[str, Any], kind: str) -> None:
    """A physics or cell BSP from its scene dict (recursive: test trees are shallow)."""
    p.tag(node["type"])
    if node["type"] == "LEAF":
        p.i32(node["leaf_index"])
        if kind == "physics":
            p.i32(node["solid"])
            put_sphere(p, node["sphere"])
            p.u32(len(node["in_polys"]))
            for poly in node["in_polys"]:
                p.u16(poly)
        return
    p.plane(node["splitting_plane"]["normal"], node["splitting_plane"]["d"])
    for child in ("pos_node", "neg_node"):
        if child in node:
            put_bsp(p, node[child], kind)
    if kind == "physics":
        put_sphere(p, node["sphere"])


def put_drawing_bsp(p: Packer) -> None:
    """A small drawing BSP (BPIn over a PORT over two leaves), only there to be skipped."""
    p.tag("BPIn").plane([1.0, 0.0, 0.0], -1.0)
    p.tag("PORT").plane([0.0, 1.0, 0.0], 0.5)
    p.tag("LEAF").i32(0)
    p.tag("LEAF").i32(1)
    p.sphere([0.0, 0.0, 1.0], 2.0).u32(2).u32(1).u16(0).u16(1).i16(0).i16(7)
    p.sphere([0.0, 0.0, 1.0], 3.0).u32(1).u16(3)


def encode_cell_struct(p: Packer, cs: dict[str, Any], drawing: bool = True) -> None:
    p.u32(len(cs["polygons"])).u32(len(cs["physics_polygons"])).u32(len(cs["portals"]))
    put_vertices(p, cs["vertices"])
    put_polygons(p, cs["polygons"])
    for portal in cs["portals"]:
        p.u16(portal)
    p.align4()
    put_bsp(p, cs["cell_bsp"], "cell")
    put_polygons(p, cs["physics_polygons"])
    put_bsp(p, cs["physics_bsp"], "physics")
    p.u32(1 if drawing else 0)
    if drawing:
        put_drawing_bsp(p)
    p.align4()


def encode_environment(env_id: int, env: dict[str, Any], drawing: bool = True) -> bytes:
    p = Packer().u32(env_id).u32(len(env["cell_structs"]))
    for key, cs in env["cell_structs"].items():
        p.u32(int(key))
        encode_cell_struct(p, cs, drawing)
    return p.getvalue()


def encode_gfx_obj(obj_id: int, g: dict[str, Any], drawing: bool = True) -> bytes:
    physics = "physics_bsp" in g
    flags = (0x1 if physics else 0) | (0x2 | 0x8 if drawing else 0)
    p = Packer().u32(obj_id).u32(flags)
    p.compressed_u32(2).u32(0x08000001).u32(0x08000002)  # surfaces
    put_vertices(p, g["vertices"])
    if physics:
        p.compressed_u32(len(g["physics_polygons"]))
        put_polygons(p, g["physics_polygons"])
        put_bsp(p, g["physics_bsp"], "physics")
    p.vec3(g["sort_center"])
    if drawing:
        p.compressed_u32(1).u16(0)
        put_polygon(p, {"vertex_ids": [0, 1, 2], "sides_type": 2, "stippling": 0})
        put_drawing_bsp(p)
        p.u32(0x11000001)  # degrade info id
    return p.getvalue()


def encode_setup(setup_id: int, s: dict[str, Any]) -> bytes:
    parts = s["parts"]
    flags = 0x1 | (0x2 if "default_scale" in s else 0) | (0x4 if s.get("allow_free_heading") else 0)
    p = Packer().u32(setup_id).u32(flags).u32(len(parts))
    for part in parts:
        p.u32(int(part, 16))
    for i in range(len(parts)):
        p.u32(0xFFFFFFFF if i == 0 else 0)  # parent index
    for scale in s.get("default_scale", ()):
        p.vec3(scale)
    p.i32(1).i32(1).i32(0).frame([0.0, 0.1, 0.2], [1.0, 0.0, 0.0, 0.0])  # one holding location
    p.i32(0)  # connection points
    placements = s.get("placement_frames", {})
    p.i32(len(placements))
    for key, placement in placements.items():
        p.i32(int(key))
        for frame in placement["frames"]:
            put_frame(p, frame)
        p.u32(2)
        p.u32(1).i32(0).u32(0x0A000001)  # Sound hook
        p.u32(5).i32(1).u16(0).u16(0x8001).u16(0x0002)  # ReplaceObject hook, 4-byte packed part id
    cyl = s.get("cyl_spheres", [])
    p.u32(len(cyl))
    for c in cyl:
        p.vec3(c["origin"]).f32(c["radius"]).f32(c["height"])
    spheres = s.get("spheres", [])
    p.u32(len(spheres))
    for sph in spheres:
        put_sphere(p, sph)
    p.f32(s.get("height", 0.0)).f32(s.get("radius", 0.0))
    p.f32(s.get("step_up_height", 0.0)).f32(s.get("step_down_height", 0.0))
    put_sphere(p, s.get("sorting_sphere", ZERO_SPHERE))
    put_sphere(p, s.get("selection_sphere", ZERO_SPHERE))
    p.i32(1).i32(0).frame([0.0, 0.0, 1.0], [1.0, 0.0, 0.0, 0.0]).u32(0xFFFFFFFF).f32(1.0).f32(5.0).f32(0.0)  # a light
    p.u32(0x03000001).u32(0).u32(0x09000001).u32(0x20000001).u32(0x34000001)
    return p.getvalue()


def encode_cell_landblock(lb: int, heights: list[int], terrain: list[int], has_objects: bool) -> bytes:
    p = Packer().u32((lb << 16) | 0xFFFF).u32(1 if has_objects else 0)
    for t in terrain:
        p.u16(t)
    for h in heights:
        p.u8(h)
    return p.align4().getvalue()


def put_stabs(p: Packer, stabs: list[dict[str, Any]]) -> None:
    p.u32(len(stabs))
    for stab in stabs:
        p.u32(int(stab["id"], 16))
        put_frame(p, stab["frame"])


def encode_landblock_info(lb: int, num_cells: int, objects: list, buildings: list, restrictions: dict) -> bytes:
    p = Packer().u32((lb << 16) | 0xFFFE).u32(num_cells)
    put_stabs(p, objects)
    p.u16(len(buildings)).u16(1 if restrictions else 0)
    for b in buildings:
        p.u32(int(b["model_id"], 16))
        put_frame(p, b["frame"])
        p.u32(b["num_leaves"]).u32(len(b["portals"]))
        for portal in b["portals"]:
            p.u16(portal["flags"]).u16(int(portal["other_cell_id"], 16)).u16(portal["other_portal_id"])
            p.u16(len(portal["stab_list"]))
            for c in portal["stab_list"]:
                p.u16(int(c, 16))
            p.align4()
    if restrictions:
        p.u16(len(restrictions)).u16(8)
        for k, v in restrictions.items():
            p.u32(k).u32(v)
    return p.getvalue()


def encode_env_cell(cell: dict[str, Any]) -> bytes:
    cell_id = int(cell["id"], 16)
    statics = cell.get("static_objects", [])
    restriction = cell.get("restriction_obj", 0)
    flags = (0x1 if cell.get("seen_outside") else 0) | (0x2 if statics else 0) | (0x8 if restriction else 0)
    portals = cell["cell_portals"]
    visible = cell["visible_cells"]
    p = Packer().u32(cell_id).u32(flags).u32(cell_id).u8(2).u8(len(portals)).u16(len(visible))
    p.u16(0x0101).u16(0x0102)  # surfaces
    p.u16(int(cell["environment_id"], 16) & 0xFFFF).u16(cell["cell_structure"])
    put_frame(p, cell["position"])
    for portal in portals:
        p.u16(portal["flags"]).u16(portal["polygon_id"]).u16(int(portal["other_cell_id"], 16))
        p.u16(portal["other_portal_id"])
    for c in visible:
        p.u16(int(c, 16))
    if statics:
        put_stabs(p, statics)
    if restriction:
        p.u32(restriction)
    return p.getvalue()


def encode_region(height_table: list[float], name: str = "Dereth") -> bytes:
    p = Packer().u32(REGION_ID).u32(1).u32(3).u16(len(name)).raw(name.encode("latin-1")).align4()
    p.i32(255).i32(255).f32(24.0).i32(8).i32(1).f32(200.0).f32(1000.0).f32(5.0)
    for h in height_table:
        p.f32(h)
    # The start of GameTime and then junk: the reader must not look past the height table.
    p.f64(0.0).u32(10).f32(7620.0).u32(360).raw(b"\xff" * 37)
    return p.getvalue()


def scene_to_dat_files(scene: dict[str, Any], drawing: bool = True) -> tuple[dict[int, bytes], dict[int, bytes]]:
    """(cell dat files, portal dat files) carrying `scene`."""
    cell: dict[int, bytes] = {ITERATION_ID: b"\x01\0\0\0\0\0\0\0\0\0\0\0"}
    portal: dict[int, bytes] = {ITERATION_ID: b"\x01\0\0\0\0\0\0\0\0\0\0\0"}
    for lb in scene["landblocks"]:
        n = int(lb["id"], 16)
        cells, buildings, objects = lb.get("env_cells", []), lb.get("buildings", []), lb.get("objects", [])
        has_objects = bool(cells or buildings or objects)
        cell[(n << 16) | 0xFFFF] = encode_cell_landblock(n, lb["heights"], lb.get("terrain", [0] * 81), has_objects)
        if has_objects:
            cell[(n << 16) | 0xFFFE] = encode_landblock_info(n, len(cells), objects, buildings, {})
        for c in cells:
            cell[int(c["id"], 16)] = encode_env_cell(c)
    portal[REGION_ID] = encode_region(scene["height_table"])
    for key, env in scene.get("environments", {}).items():
        portal[int(key, 16)] = encode_environment(int(key, 16), env, drawing)
    for key, g in scene.get("gfx_objs", {}).items():
        portal[int(key, 16)] = encode_gfx_obj(int(key, 16), g, drawing)
    for key, s in scene.get("setups", {}).items():
        portal[int(key, 16)] = encode_setup(int(key, 16), s)
    return cell, portal


def write_scene_dats(directory: str | Path, scene: dict[str, Any], *, fanout: int = 61, seed: int = 1,
                     cell_block_size: int = 256, portal_block_size: int = 1024) -> Path:  # fmt: skip
    """Write `client_cell_1.dat` and `client_portal.dat` for `scene` into `directory`."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    cell, portal = scene_to_dat_files(scene)
    write_dat(directory / "client_cell_1.dat", cell, block_size=cell_block_size, data_set=DATA_SET_CELL,
              subset=1, fanout=fanout, seed=seed)  # fmt: skip
    write_dat(directory / "client_portal.dat", portal, block_size=portal_block_size, data_set=DATA_SET_PORTAL,
              fanout=fanout, seed=seed + 1)  # fmt: skip
    return directory
