"""The built-in demo world: four landblocks of generated terrain.

Deterministic (no randomness), so `clients/demo/demo.json` is exactly what
`build_demo_scene()` returns; a test checks the two agree. The layout, in
global metres over the 384 m x 384 m square of landblocks A9B4 (south-west),
AAB4, A9B5 and AAB5 (north-east):

- rolling hills everywhere at about 40 m;
- a mesa 90 m high in the north-east (x 240..336, y 216..336), whose west
  face rises 50 m over one 24 m cell (normal z about 0.43, far below
  FloorZ 0.664: a slope nothing can walk up);
- a ramp up to the mesa from the south (x 264..312, y 72..216), about 8 m
  per cell, easily walkable;
- the mesa's north edge drops 50 m in one cell: a ledge to walk off;
- a flat pad at 40 m in the north-west (x 72..144, y 264..336, landblock
  A9B5) with a small house (a one-room EnvCell 0xA9B50100 whose doorway
  faces south, inside a building shell GfxObj), a cylsphere pillar, a
  boulder (a Setup of spheres) and a low box platform.

The house and the objects are generated here (`build_demo_scene`), with
their physics BSPs built from axis-aligned boxes: a solid box is a chain of
its six outward face planes ending in a solid leaf holding its faces, a
union of boxes is split by planes that separate them, and the room is the
chain of its inward wall planes (see the formats README, section "indoor
cells, buildings and objects").
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

__all__ = [
    "BOULDER",
    "DEMO_LANDBLOCKS",
    "DOOR",
    "HOUSE",
    "HOUSE_CELL",
    "MESA_TOP",
    "ORIGIN_LANDBLOCK",
    "PAD_HEIGHT",
    "PILLAR",
    "PILLAR_RADIUS",
    "PLATFORM",
    "Footprint",
    "build_demo_scene",
    "demo_footprints",
    "demo_scene_path",
    "global_to_cell",
    "is_indoor",
    "write_demo_scene",
]

ORIGIN_LANDBLOCK = 0xA9B4  # the south-west landblock: global (0, 0)
DEMO_LANDBLOCKS = (0xA9B4, 0xAAB4, 0xA9B5, 0xAAB5)
MESA_TOP = 90
_MESA_X = range(10, 15)  # global vertex columns of the mesa top
_MESA_Y = range(9, 15)
_RAMP_X = range(11, 14)
_RAMP_Y = range(3, 9)  # vertex rows climbing from the hills to the top
PAD_HEIGHT = 40  # the flat pad the house and the objects stand on
_PAD_X = range(3, 7)  # global vertex columns x 72..144
_PAD_Y = range(11, 15)  # rows y 264..336


def _hills(gx: int, gy: int) -> float:
    return 40.0 + 5.0 * math.sin(gx * 0.8) * math.cos(gy * 0.6) + 3.0 * math.sin(0.5 * gx + 0.9 * gy)


def vertex_height(gx: int, gy: int) -> int:
    """Height in metres (= height byte: the table is 1 m per step) of global vertex (gx, gy)."""
    if gx in _MESA_X and gy in _MESA_Y:
        return MESA_TOP
    if gx in _PAD_X and gy in _PAD_Y:
        return PAD_HEIGHT
    base = _hills(gx, gy)
    if gx in _RAMP_X and gy in _RAMP_Y:
        start = _hills(gx, _RAMP_Y.start)
        t = (gy - _RAMP_Y.start) / (_MESA_Y.start - _RAMP_Y.start)
        return int(round(start + (MESA_TOP - start) * t))
    return int(round(base))


def build_demo_scene() -> dict[str, Any]:
    """The demo scene as an acphys-scene/1 dict."""
    ox, oy = ORIGIN_LANDBLOCK >> 8, ORIGIN_LANDBLOCK & 0xFF
    landblocks = []
    for lb in DEMO_LANDBLOCKS:
        bx, by = (lb >> 8) - ox, (lb & 0xFF) - oy
        heights = [vertex_height(bx * 8 + x, by * 8 + y) for x in range(9) for y in range(9)]
        landblock: dict[str, Any] = {"id": f"{lb:04X}", "heights": heights}
        if lb == _VILLAGE_LANDBLOCK:
            landblock.update(_village_landblock())
        landblocks.append(landblock)
    return {
        "format": "acphys-scene/1",
        "name": "acphys-demo",
        "height_table": [float(i) for i in range(256)],
        **_village_models(),
        "landblocks": landblocks,
    }


# -- the village: a house, a pillar, a boulder and a platform on the flat pad ------------------
# Places are global demo metres; the scene stores them in the frame of landblock A9B5.
_VILLAGE_LANDBLOCK = 0xA9B5
_VILLAGE_OFFSET = (0.0, 192.0)  # global position of A9B5's south-west corner
HOUSE = (108.0, 300.0)  # the house's origin (floor centre); landblock-local (108, 108)
HOUSE_CELL = 0xA9B50100  # its room
_HALF_X, _HALF_Y = 4.0, 3.0  # outer half extents of the shell
_WALL = 0.25
_ROOM_HEIGHT = 3.0
_ROOF = 0.25
_DOOR_HALF_WIDTH = 0.75
_DOOR_HEIGHT = 2.25
DOOR = (HOUSE[0], HOUSE[1] - _HALF_Y)  # the middle of the doorway's outer edge (it faces south)
PILLAR = (132.0, 282.0)
PILLAR_RADIUS = 0.6
_PILLAR_HEIGHT = 4.0
BOULDER = (84.0, 282.0)
_BOULDER_SPHERES = (((0.0, 0.0, 1.1), 1.2), ((1.35, 0.4, 0.55), 0.6))
PLATFORM = (84.0, 324.0)
_PLATFORM_HALF = (2.0, 1.5)
_PLATFORM_HEIGHT = 0.4

_DOOR_POLYGON = 0  # the doorway's polygon id among the room's drawing polygons
_ENV_ID = "0D000001"
_SHELL_ID = "01000001"
_PLATFORM_ID = "01000002"
_PILLAR_PART_ID = "01000003"
_BOULDER_PART_ID = "01000004"
_PILLAR_SETUP_ID = "02000001"
_BOULDER_SETUP_ID = "02000002"

Vec = tuple[float, float, float]


@dataclass(frozen=True, slots=True)
class _Box:
    lo: Vec
    hi: Vec

    def corners(self) -> list[Vec]:
        return [(x, y, z) for x in (self.lo[0], self.hi[0]) for y in (self.lo[1], self.hi[1])
                for z in (self.lo[2], self.hi[2])]


_PLATFORM_BOX = _Box((-_PLATFORM_HALF[0], -_PLATFORM_HALF[1], 0.0),
                     (_PLATFORM_HALF[0], _PLATFORM_HALF[1], _PLATFORM_HEIGHT))


def _shell_boxes() -> list[_Box]:
    """The house's walls and roof in its own frame (origin at the floor's centre)."""
    hx, hy, w, h, dw, dh = _HALF_X, _HALF_Y, _WALL, _ROOM_HEIGHT, _DOOR_HALF_WIDTH, _DOOR_HEIGHT
    return [
        _Box((-hx, -hy, 0.0), (-dw, -hy + w, h)),  # south wall, west of the door
        _Box((dw, -hy, 0.0), (hx, -hy + w, h)),  # south wall, east of the door
        _Box((-dw, -hy, dh), (dw, -hy + w, h)),  # over the door
        _Box((-hx, hy - w, 0.0), (hx, hy, h)),  # north wall
        _Box((-hx, -hy + w, 0.0), (-hx + w, hy - w, h)),  # west wall
        _Box((hx - w, -hy + w, 0.0), (hx, hy - w, h)),  # east wall
        _Box((-hx, -hy, h), (hx, hy, h + _ROOF)),  # roof slab
    ]


def _sub(a: Vec, b: Vec) -> Vec:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _cross(a: Vec, b: Vec) -> Vec:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot(a: Vec, b: Vec) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _axis(axis: int, sign: float) -> list[float]:
    n = [0.0, 0.0, 0.0]
    n[axis] = sign
    return n


def _plane(axis: int, sign: float, value: float) -> dict[str, Any]:
    """The plane `axis = value` with normal `sign` along the axis: dot(n, p) + d = 0."""
    return {"normal": _axis(axis, sign), "d": -sign * value + 0.0}


def _sphere(points: list[Vec]) -> dict[str, Any]:
    """A bounding sphere: the points' box centre and the farthest point, rounded outwards."""
    c = tuple((min(p[i] for p in points) + max(p[i] for p in points)) / 2.0 for i in range(3))
    r = max(math.dist(c, p) for p in points)
    return {"origin": [round(v, 6) for v in c], "radius": math.ceil(r * 1e4) / 1e4}


class _Mesh:
    """A vertex array and a polygon table, built face by face."""

    def __init__(self) -> None:
        self.ids: dict[Vec, int] = {}
        self.polys: dict[int, list[int]] = {}
        self.points: dict[int, list[Vec]] = {}

    def vertex(self, p: Vec) -> int:
        return self.ids.setdefault(p, len(self.ids))

    def rect(self, axis: int, value: float, lo: tuple[float, float], hi: tuple[float, float],
             facing: float) -> int:
        """A rectangle in the plane `axis = value` over [lo, hi] of the other two axes
        (in x, y, z order), wound counter-clockwise seen from the side `facing` (+1/-1)."""
        u, v = [a for a in range(3) if a != axis]
        pts = []
        for a, b in ((lo[0], lo[1]), (hi[0], lo[1]), (hi[0], hi[1]), (lo[0], hi[1])):
            p = [0.0, 0.0, 0.0]
            p[axis], p[u], p[v] = value, a, b
            pts.append((p[0] + 0.0, p[1] + 0.0, p[2] + 0.0))
        n = _cross(_sub(pts[1], pts[0]), _sub(pts[2], pts[0]))
        if _dot(n, tuple(_axis(axis, facing))) < 0.0:  # type: ignore[arg-type]
            pts.reverse()
        pid = len(self.polys)
        self.polys[pid] = [self.vertex(p) for p in pts]
        self.points[pid] = pts
        return pid

    def box_faces(self, box: _Box) -> list[tuple[int, float, float, int]]:
        """The six outward faces of a solid box: (axis, sign, value, polygon id)."""
        faces = []
        for axis in range(3):
            u, v = [a for a in range(3) if a != axis]
            lo, hi = (box.lo[u], box.lo[v]), (box.hi[u], box.hi[v])
            for sign, value in ((-1.0, box.lo[axis]), (1.0, box.hi[axis])):
                faces.append((axis, sign, value, self.rect(axis, value, lo, hi, sign)))
        return faces

    def vertices_dict(self) -> dict[str, list[float]]:
        return {str(i): list(p) for p, i in sorted(self.ids.items(), key=lambda kv: kv[1])}

    def polygons_dict(self, ids: list[int] | None = None) -> dict[str, dict[str, Any]]:
        return {str(pid): {"vertex_ids": self.polys[pid], "sides_type": 0, "stippling": 0, "pos_surface": 0,
                           "neg_surface": -1}
                for pid in (sorted(self.polys) if ids is None else ids)}

    def poly_points(self, ids: list[int]) -> list[Vec]:
        return [p for pid in ids for p in self.points[pid]]


def _leaf(solid: bool, sphere: dict[str, Any], polys: list[int]) -> dict[str, Any]:
    return {"type": "LEAF", "leaf_index": -1, "solid": int(solid), "sphere": sphere, "in_polys": polys}


def _node(plane: dict[str, Any], pos: dict[str, Any], neg: dict[str, Any], sphere: dict[str, Any]) -> dict[str, Any]:
    return {"type": "BPnN", "splitting_plane": plane, "pos_node": pos, "neg_node": neg, "sphere": sphere}


def _number_leaves(node: dict[str, Any], start: int = 0) -> int:
    """Give the leaves their indices in depth-first order (positive side first); the count."""
    if node["type"] == "LEAF":
        node["leaf_index"] = start
        return start + 1
    return _number_leaves(node["neg_node"], _number_leaves(node["pos_node"], start))


def _solid_box_bsp(mesh: _Mesh, box: _Box) -> dict[str, Any]:
    """One solid box: its face planes in a chain, outside on the positive side of
    each, ending in a solid leaf that holds the six faces."""
    faces = mesh.box_faces(box)
    sphere = _sphere(box.corners())
    node = _leaf(True, sphere, sorted(f[3] for f in faces))
    for axis, sign, value, _ in reversed(faces):
        node = _node(_plane(axis, sign, value), _leaf(False, sphere, []), node, sphere)
    return node


def _split(boxes: list[_Box]) -> tuple[int, float]:
    """A plane `axis = value` with every box on one side of it, as balanced as any."""
    best: tuple[int, int, float] | None = None
    for axis in (2, 1, 0):
        for value in sorted({b.lo[axis] for b in boxes} | {b.hi[axis] for b in boxes}):
            above = sum(b.lo[axis] >= value for b in boxes)
            below = sum(b.hi[axis] <= value for b in boxes)
            if above and below and above + below == len(boxes):
                worst = max(above, below)
                if best is None or worst < best[0]:
                    best = (worst, axis, value)
    if best is None:
        raise ValueError("boxes that no axis-aligned plane separates")
    return best[1], best[2]


def _union_bsp(mesh: _Mesh, boxes: list[_Box]) -> dict[str, Any]:
    if len(boxes) == 1:
        return _solid_box_bsp(mesh, boxes[0])
    axis, value = _split(boxes)
    above = [b for b in boxes if b.lo[axis] >= value]
    below = [b for b in boxes if b.hi[axis] <= value]
    sphere = _sphere([p for b in boxes for p in b.corners()])
    return _node(_plane(axis, 1.0, value), _union_bsp(mesh, above), _union_bsp(mesh, below), sphere)


def _solid_gfx_obj(boxes: list[_Box]) -> dict[str, Any]:
    """A GfxObj whose physics shape is a union of disjoint solid boxes."""
    mesh = _Mesh()
    bsp = _union_bsp(mesh, boxes)
    leaves = _number_leaves(bsp)
    corners = [p for b in boxes for p in b.corners()]
    return {
        "vertices": mesh.vertices_dict(),
        "physics_polygons": mesh.polygons_dict(),
        "physics_bsp": bsp,
        "num_physics_leaves": leaves,
        "sort_center": _sphere(corners)["origin"],
    }


def _shell_gfx_obj() -> dict[str, Any]:
    return _solid_gfx_obj(_shell_boxes())


def _drawing_gfx_obj(box: _Box) -> dict[str, Any]:
    """A drawing-only part (no physics polygons): the object's shape comes from its Setup."""
    mesh = _Mesh()
    for p in box.corners():
        mesh.vertex(p)
    return {"vertices": mesh.vertices_dict(), "sort_center": _sphere(box.corners())["origin"]}


def _setup(part: str, radius: float, height: float, spheres: list[dict[str, Any]],
           cyl_spheres: list[dict[str, Any]]) -> dict[str, Any]:
    """A one-part Setup whose collision shape is its spheres or cylspheres (its part has no physics BSP)."""
    return {
        "parts": [part],
        "placement_frames": {"0": {"frames": [{"origin": [0.0, 0.0, 0.0], "orientation": [1.0, 0.0, 0.0, 0.0]}]}},
        "spheres": spheres,
        "cyl_spheres": cyl_spheres,
        "height": height,
        "radius": radius,
        "step_up_height": 0.0,
        "step_down_height": 0.0,
        "allow_free_heading": False,
    }


def _room_cell_struct() -> dict[str, Any]:
    """The house's one room: floor, ceiling and four walls facing in, a doorway in
    the south wall whose portal polygon faces out (towards the other side)."""
    hx, hy, h = _HALF_X - _WALL, _HALF_Y - _WALL, _ROOM_HEIGHT
    dw, dh = _DOOR_HALF_WIDTH, _DOOR_HEIGHT
    mesh = _Mesh()
    # (axis, inward sign, value, polygons of that face, solid behind it)
    floor = mesh.rect(2, 0.0, (-hx, -hy), (hx, hy), 1.0)
    east = mesh.rect(0, hx, (-hy, 0.0), (hy, h), -1.0)
    ceiling = mesh.rect(2, h, (-hx, -hy), (hx, hy), -1.0)
    west = mesh.rect(0, -hx, (-hy, 0.0), (hy, h), 1.0)
    north = mesh.rect(1, hy, (-hx, 0.0), (hx, h), -1.0)
    south = [
        mesh.rect(1, -hy, (-hx, dh), (hx, h), 1.0),  # over the doorway, full width
        mesh.rect(1, -hy, (-hx, 0.0), (-dw, dh), 1.0),  # west of the doorway
        mesh.rect(1, -hy, (dw, 0.0), (hx, dh), 1.0),  # east of the doorway
    ]
    faces = [
        (2, 1.0, 0.0, [floor], True),
        (0, -1.0, hx, [east], True),
        (2, -1.0, h, [ceiling], True),
        (0, 1.0, -hx, [west], True),
        (1, -1.0, hy, [north], True),
        (1, 1.0, -hy, south, False),  # the doorway: open behind
    ]
    physics_ids = sorted(mesh.polys)
    room = _sphere(mesh.poly_points(physics_ids))
    # the doorway's portal: a drawing polygon (own id space, id 0) on the same vertex array
    door_vertices = mesh.polys.pop(mesh.rect(1, -hy, (-dw, 0.0), (dw, dh), -1.0))
    drawing = {str(_DOOR_POLYGON): {"vertex_ids": door_vertices, "sides_type": 0, "stippling": 0,
                                    "pos_surface": 0, "neg_surface": -1}}

    physics: dict[str, Any] = _leaf(False, room, physics_ids)
    cell: dict[str, Any] = {"type": "LEAF", "leaf_index": 0}
    for axis, sign, value, polys, solid in reversed(faces):
        plane = _plane(axis, sign, value)
        physics = _node(plane, physics, _leaf(solid, _sphere(mesh.poly_points(polys)), polys), room)
        cell = {"type": "BPnn", "splitting_plane": plane, "pos_node": cell}
    _number_leaves(physics)
    return {
        "vertices": mesh.vertices_dict(),
        "polygons": drawing,
        "portals": [_DOOR_POLYGON],
        "cell_bsp": cell,
        "physics_polygons": mesh.polygons_dict(physics_ids),
        "physics_bsp": physics,
    }


def _village_models() -> dict[str, Any]:
    """The portal-dat side of the village: the room's Environment, GfxObjs and Setups."""
    pillar_box = _Box((-PILLAR_RADIUS, -PILLAR_RADIUS, 0.0), (PILLAR_RADIUS, PILLAR_RADIUS, _PILLAR_HEIGHT))
    lo = tuple(round(min(c[i] - r for c, r in _BOULDER_SPHERES), 4) for i in range(3))
    hi = tuple(round(max(c[i] + r for c, r in _BOULDER_SPHERES), 4) for i in range(3))
    boulder_box = _Box((lo[0], lo[1], 0.0), (hi[0], hi[1], hi[2]))
    boulder_radius = max(math.hypot(c[0], c[1]) + r for c, r in _BOULDER_SPHERES)
    return {
        "environments": {_ENV_ID: {"cell_structs": {"0": _room_cell_struct()}}},
        "gfx_objs": {
            _SHELL_ID: _shell_gfx_obj(),
            _PLATFORM_ID: _solid_gfx_obj([_PLATFORM_BOX]),
            _PILLAR_PART_ID: _drawing_gfx_obj(pillar_box),
            _BOULDER_PART_ID: _drawing_gfx_obj(boulder_box),
        },
        "setups": {
            _PILLAR_SETUP_ID: _setup(_PILLAR_PART_ID, PILLAR_RADIUS, _PILLAR_HEIGHT, spheres=[], cyl_spheres=[
                {"origin": [0.0, 0.0, 0.0], "radius": PILLAR_RADIUS, "height": _PILLAR_HEIGHT}]),
            _BOULDER_SETUP_ID: _setup(_BOULDER_PART_ID, round(boulder_radius, 4), hi[2], cyl_spheres=[], spheres=[
                {"origin": list(c), "radius": r} for c, r in _BOULDER_SPHERES]),
        },
    }


def _local(x: float, y: float) -> tuple[float, float]:
    return x - _VILLAGE_OFFSET[0], y - _VILLAGE_OFFSET[1]


def _frame(xy: tuple[float, float]) -> dict[str, Any]:
    x, y = _local(*xy)
    return {"origin": [x, y, float(PAD_HEIGHT)], "orientation": [1.0, 0.0, 0.0, 0.0]}


def _village_landblock() -> dict[str, Any]:
    """The EnvCell, building and objects of landblock A9B5."""
    return {
        "env_cells": [{
            "id": f"{HOUSE_CELL:08X}",
            "environment_id": _ENV_ID,
            "cell_structure": 0,
            "position": _frame(HOUSE),
            "cell_portals": [{"flags": 0, "polygon_id": _DOOR_POLYGON, "other_cell_id": "FFFF", "other_portal_id": 65535}],
            "visible_cells": [f"{HOUSE_CELL & 0xFFFF:04X}"],
            "seen_outside": True,
            "static_objects": [],
            "restriction_obj": 0,
        }],
        "buildings": [{
            "model_id": _SHELL_ID,
            "frame": _frame(HOUSE),
            "num_leaves": _shell_gfx_obj()["num_physics_leaves"],
            "portals": [{"flags": 0, "other_cell_id": f"{HOUSE_CELL & 0xFFFF:04X}", "other_portal_id": 0,
                         "stab_list": [f"{HOUSE_CELL & 0xFFFF:04X}"]}],
        }],
        "objects": [
            {"id": _PILLAR_SETUP_ID, "frame": _frame(PILLAR)},
            {"id": _BOULDER_SETUP_ID, "frame": _frame(BOULDER)},
            {"id": _PLATFORM_ID, "frame": _frame(PLATFORM)},
        ],
    }


@dataclass(frozen=True, slots=True)
class Footprint:
    """Where a building or an object stands, for the map (global metres).

    `shape` is "rect" (`a` = x0, y0, x1, y1) or "circle" (`a` = x, y, radius)."""

    kind: str  # "building", "door" or "object"
    name: str
    shape: str
    a: tuple[float, ...]


def demo_footprints() -> list[Footprint]:
    """The house (with its doorway) and the objects, as seen from above."""
    hx, hy = HOUSE
    out = [
        Footprint("building", "house", "rect", (hx - _HALF_X, hy - _HALF_Y, hx + _HALF_X, hy + _HALF_Y)),
        Footprint("door", "doorway", "rect", (DOOR[0] - _DOOR_HALF_WIDTH, DOOR[1], DOOR[0] + _DOOR_HALF_WIDTH,
                                              DOOR[1] + _WALL)),
        Footprint("object", "pillar", "circle", (PILLAR[0], PILLAR[1], PILLAR_RADIUS)),
    ]
    for (cx, cy, _), r in _BOULDER_SPHERES:
        out.append(Footprint("object", "boulder", "circle", (BOULDER[0] + cx, BOULDER[1] + cy, r)))
    px, py = PLATFORM
    out.append(Footprint("object", "platform", "rect", (px - _PLATFORM_HALF[0], py - _PLATFORM_HALF[1],
                                                        px + _PLATFORM_HALF[0], py + _PLATFORM_HALF[1])))
    return out


def global_to_cell(x: float, y: float) -> tuple[int, float, float]:
    """Global demo metres to (outdoor cell id, landblock-local x, y)."""
    bx, by = int(x // 192.0), int(y // 192.0)
    bx, by = min(max(bx, 0), 1), min(max(by, 0), 1)
    lx, ly = x - bx * 192.0, y - by * 192.0
    lb = ((ORIGIN_LANDBLOCK >> 8) + bx) << 8 | ((ORIGIN_LANDBLOCK & 0xFF) + by)
    cx, cy = min(max(int(lx // 24.0), 0), 7), min(max(int(ly // 24.0), 0), 7)
    return (lb << 16) | (cx * 8 + cy + 1), lx, ly


def is_indoor(cell_id: int) -> bool:
    """An EnvCell (index 0x0100 and up) rather than an outdoor LandCell (1..64)."""
    return (cell_id & 0xFFFF) >= 0x100


def demo_scene_path() -> Path:
    """Where the shipped demo scene file is (package data of `clients`)."""
    return Path(str(resources.files("clients").joinpath("demo", "demo.json")))


def write_demo_scene(path: Path | None = None) -> Path:
    """Regenerate the shipped file (run `python -m clients.demo.world`)."""
    path = path or demo_scene_path()
    path.parent.mkdir(parents=True, exist_ok=True)
    scene = build_demo_scene()
    with open(path, "w", encoding="utf-8") as f:
        json.dump(scene, f, separators=(",", ":"))
        f.write("\n")
    return path


if __name__ == "__main__":
    print(write_demo_scene())
