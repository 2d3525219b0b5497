"""Structural sanity of a scene dict read from dats: every reference resolves.

Used on real client dats (when ACPHYS_DAT_DIR is set) and on the shared
reference dats, so the checks themselves are exercised on every run.
"""

from __future__ import annotations

from typing import Any


def _bsp_nodes(root: dict[str, Any]) -> list[dict[str, Any]]:
    out, stack = [], [root]
    while stack:
        node = stack.pop()
        out.append(node)
        stack.extend(node[k] for k in ("pos_node", "neg_node") if k in node)
    return out


def _check_polygons(polygons: dict[str, Any], vertices: dict[str, Any], where: str) -> None:
    for key, poly in polygons.items():
        assert len(poly["vertex_ids"]) >= 3, f"{where} polygon {key} has < 3 vertices"
        for v in poly["vertex_ids"]:
            assert str(v) in vertices, f"{where} polygon {key} names missing vertex {v}"


def _check_physics_bsp(root: dict[str, Any], polygons: dict[str, Any], where: str) -> None:
    for node in _bsp_nodes(root):
        assert node["type"] in {"BPnn", "BPIn", "BpIN", "BpnN", "BPIN", "BPnN", "LEAF"}, where
        assert node["sphere"]["radius"] >= 0.0, where
        for poly in node.get("in_polys", ()):
            assert str(poly) in polygons, f"{where} physics BSP leaf names missing polygon {poly}"


def check_portal_objects(scene: dict[str, Any]) -> None:
    """GfxObjs, Setups and Environments refer only to things that exist."""
    gfx_objs = scene.get("gfx_objs", {})
    for key, g in gfx_objs.items():
        if "physics_polygons" in g:
            _check_polygons(g["physics_polygons"], g["vertices"], f"GfxObj {key}")
            _check_physics_bsp(g["physics_bsp"], g["physics_polygons"], f"GfxObj {key}")
    for key, s in scene.get("setups", {}).items():
        assert s["parts"], f"Setup {key} has no parts"
        for part in s["parts"]:
            assert part in gfx_objs, f"Setup {key} part {part} not collected"
        for placement in s["placement_frames"].values():
            assert len(placement["frames"]) == len(s["parts"])
    for key, env in scene.get("environments", {}).items():
        for index, cs in env["cell_structs"].items():
            where = f"Environment {key} struct {index}"
            _check_polygons(cs["polygons"], cs["vertices"], where)
            _check_polygons(cs["physics_polygons"], cs["vertices"], where)
            _check_physics_bsp(cs["physics_bsp"], cs["physics_polygons"], where)
            for portal in cs["portals"]:
                assert str(portal) in cs["polygons"], f"{where} portal polygon {portal} missing"


def check_landblock(lb: dict[str, Any], scene: dict[str, Any]) -> None:
    """A landblock's cells, buildings and objects are consistent and their models were collected."""
    assert len(lb["id"]) == 4
    assert len(lb["heights"]) == 81 and all(0 <= h <= 255 for h in lb["heights"])
    assert len(lb["terrain"]) == 81 and all(0 <= t <= 0xFFFF for t in lb["terrain"])
    known = {**scene.get("gfx_objs", {}), **scene.get("setups", {})}
    cells = lb.get("env_cells", [])
    ids = [c["id"] for c in cells]
    assert ids == [f"{lb['id']}{0x100 + i:04X}" for i in range(len(cells))], "EnvCells not consecutive from 0100"
    short_ids = {i[4:] for i in ids}
    for cell in cells:
        env = scene["environments"][cell["environment_id"]]
        cs = env["cell_structs"][str(cell["cell_structure"])]
        for portal in cell["cell_portals"]:
            assert str(portal["polygon_id"]) in cs["polygons"], f"{cell['id']} portal polygon missing"
            other = portal["other_cell_id"]
            if other != "FFFF":
                assert other in short_ids, f"{cell['id']} portal to unknown cell {other}"
                assert other in cell["visible_cells"], f"{cell['id']} stab list lacks neighbour {other}"
        for stab in cell["static_objects"]:
            assert stab["id"] in known, f"{cell['id']} static object {stab['id']} not collected"
    for b in lb.get("buildings", []):
        assert b["model_id"] in known
        for portal in b["portals"]:
            assert portal["other_cell_id"] in short_ids, f"building door to unknown cell {portal['other_cell_id']}"
    for obj in lb.get("objects", []):
        assert obj["id"] in known


def check_scene(scene: dict[str, Any]) -> None:
    assert len(scene["height_table"]) == 256
    assert all(a <= b for a, b in zip(scene["height_table"], scene["height_table"][1:]))
    check_portal_objects(scene)
    for lb in scene["landblocks"]:
        check_landblock(lb, scene)
