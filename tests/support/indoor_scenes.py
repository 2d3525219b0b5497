"""Small synthetic indoor worlds for scenario tests, as acphys-scene/1 dicts.

Everything here builds plain scene dictionaries (formats README, section
"indoor cells, buildings and objects"), so the scenarios go through the same
loader as the shared reference scenes:

- `Solid`: a convex solid given by its faces (outward polygons); `box_solid`
  and `wedge_solid` make the usual ones.
- `room_struct`: an axis-aligned box room as a CellStruct (physics polygons =
  the 6 inner faces, walls split around doorways, portal polygons, a cell BSP
  of pos-node half-spaces and a physics BSP), optionally with convex solids
  standing inside it (a step, a ramp, a slope, a low ceiling).
- `convex_struct`: any convex cell from its faces (e.g. a sloping corridor).
- `gfx_obj`: a GfxObj whose physics BSP is a union of convex solids (a wall, a
  roof box, a building shell); `shell_boxes` makes the walls and roof of a
  building around a room, with a door gap.
- `SceneBuilder`: one landblock of flat terrain with environments, GfxObjs,
  EnvCells, buildings and static objects; `.scene()` / `.world()`.

The BSPs follow the shape the client's own trees have in the shared scenes:
a room's physics BSP is a chain of its inward face planes (the negative child
of each is a leaf with that face's polygons, solid unless the face holds a
portal; the innermost positive region lists every room polygon), and a
convex solid's is a chain of its outward face planes (positive children are
empty leaves, the innermost negative leaf is solid and lists the faces).
Several solids are split apart by axis-aligned planes. Every physics node
carries a bounding sphere of the polygons below it; every internal physics
node has both children (`BPnN`). Cell BSPs are `BPnn` chains ending in a
leaf: the cell is the intersection of the positive half-spaces.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any
from collections.abc import Iterable, Sequence

import engine

Point = tuple[float, float, float]

#: height byte b -> b * 0.5 m (as tests/scenes.py)
HEIGHT_TABLE = [b * 0.5 for b in range(256)]
#: the landblock every builder world uses, and its flat ground
LANDBLOCK = 0xA9B4
GROUND_BYTE = 100
GROUND = GROUND_BYTE * 0.5  # 50 m
ENV_ID = 0x0D000001
IDENTITY = (1.0, 0.0, 0.0, 0.0)

#: the order of a box cell's faces in the shared scenes: floor, east, ceiling, west, south, north
FACE_ORDER = ("-z", "+x", "+z", "-x", "-y", "+y")
AXES = {"-x": (0, -1.0), "+x": (0, 1.0), "-y": (1, -1.0), "+y": (1, 1.0), "-z": (2, -1.0), "+z": (2, 1.0)}


# -- vector helpers --------------------------------------------------------------------


def _sub(a: Sequence[float], b: Sequence[float]) -> Point:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _cross(a: Sequence[float], b: Sequence[float]) -> Point:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _dot(a: Sequence[float], b: Sequence[float]) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _unit(a: Sequence[float]) -> Point:
    n = math.sqrt(_dot(a, a))
    return (a[0] / n, a[1] / n, a[2] / n)


def fan_normal(points: Sequence[Point]) -> Point:
    """The polygon normal as ACE's make_plane computes it (CCW = front)."""
    s = (0.0, 0.0, 0.0)
    for i in range(1, len(points) - 1):
        c = _cross(_sub(points[i], points[0]), _sub(points[i + 1], points[0]))
        s = (s[0] + c[0], s[1] + c[1], s[2] + c[2])
    return _unit(s)


def plane_of(points: Sequence[Point], facing: Sequence[float] | None = None) -> dict[str, Any]:
    """The scene plane through `points` (normal along `facing` if given)."""
    n = fan_normal(points)
    if facing is not None and _dot(n, facing) < 0.0:
        n = (-n[0], -n[1], -n[2])
    d = -sum(_dot(n, p) for p in points) / len(points)
    return {"normal": [n[0] + 0.0, n[1] + 0.0, n[2] + 0.0], "d": d + 0.0}


def oriented(points: Sequence[Point], facing: Sequence[float]) -> list[Point]:
    """`points` in the order whose make_plane normal points along `facing`."""
    pts: list[Point] = [(float(p[0]), float(p[1]), float(p[2])) for p in points]
    if _dot(fan_normal(pts), facing) < 0.0:
        pts.reverse()
    return pts


def axis_rect(axis: int, value: float, lo: Sequence[float], hi: Sequence[float]) -> list[Point]:
    """The rectangle on the plane `coordinate[axis] = value` spanning lo..hi in
    the other two coordinates (unordered; `oriented` fixes the winding)."""
    u, v = [a for a in range(3) if a != axis]
    out = []
    for cu, cv in ((lo[u], lo[v]), (hi[u], lo[v]), (hi[u], hi[v]), (lo[u], hi[v])):
        p = [0.0, 0.0, 0.0]
        p[axis], p[u], p[v] = value, cu, cv
        out.append((p[0], p[1], p[2]))
    return out


def _sphere_of(points: Iterable[Point]) -> dict[str, Any]:
    pts = list(points)
    lo = [min(p[i] for p in pts) for i in range(3)]
    hi = [max(p[i] for p in pts) for i in range(3)]
    c = [(lo[i] + hi[i]) / 2 for i in range(3)]
    r = max(math.sqrt(_dot(_sub(p, c), _sub(p, c))) for p in pts)
    return {"origin": c, "radius": r + 1e-4}


# -- meshes and solids -------------------------------------------------------------------


class Mesh:
    """A vertex array with physics and drawing polygons (one id space for both)."""

    def __init__(self) -> None:
        self.vertices: dict[int, Point] = {}
        self._vertex_ids: dict[Point, int] = {}
        self.physics: dict[int, list[int]] = {}
        self.drawing: dict[int, list[int]] = {}
        self._next_poly = 0

    def vertex(self, p: Sequence[float]) -> int:
        key = (round(p[0], 9) + 0.0, round(p[1], 9) + 0.0, round(p[2], 9) + 0.0)
        vid = self._vertex_ids.get(key)
        if vid is None:
            vid = self._vertex_ids[key] = len(self.vertices)
            self.vertices[vid] = key
        return vid

    def _add(self, table: dict[int, list[int]], points: Sequence[Point], facing: Sequence[float]) -> int:
        pid = self._next_poly
        self._next_poly += 1
        table[pid] = [self.vertex(p) for p in oriented(points, facing)]
        return pid

    def physics_poly(self, points: Sequence[Point], facing: Sequence[float]) -> int:
        return self._add(self.physics, points, facing)

    def drawing_poly(self, points: Sequence[Point], facing: Sequence[float]) -> int:
        return self._add(self.drawing, points, facing)

    def points_of(self, pid: int) -> list[Point]:
        ids = self.physics.get(pid) or self.drawing[pid]
        return [self.vertices[i] for i in ids]

    @staticmethod
    def _poly_dict(ids: list[int]) -> dict[str, Any]:
        return {"vertex_ids": ids, "sides_type": 0, "stippling": 0, "pos_surface": 0, "neg_surface": -1}

    def vertices_dict(self) -> dict[str, list[float]]:
        return {str(k): list(v) for k, v in self.vertices.items()}

    def physics_dict(self) -> dict[str, Any]:
        return {str(k): self._poly_dict(v) for k, v in self.physics.items()}

    def drawing_dict(self) -> dict[str, Any]:
        return {str(k): self._poly_dict(v) for k, v in self.drawing.items()}


@dataclass
class Solid:
    """A convex solid: faces as (points, outward normal); `planes` are the
    outward planes bounding it (by default one per face)."""

    faces: list[tuple[list[Point], Point]]
    planes: list[dict[str, Any]] = field(default_factory=list)

    def __post_init__(self) -> None:
        if not self.planes:
            self.planes = [plane_of(pts, n) for pts, n in self.faces]

    def bbox(self) -> tuple[list[float], list[float]]:
        pts = [p for f, _ in self.faces for p in f]
        return [min(p[i] for p in pts) for i in range(3)], [max(p[i] for p in pts) for i in range(3)]

    def without_faces_on(self, planes: Sequence[tuple[int, float]]) -> Solid:
        """Drop the faces lying on any of the axis planes (axis, value), e.g. the
        floor under a step that stands on a room's floor. Its bounding planes
        are kept only for the faces that stay (the room bounds the rest)."""
        keep = []
        for pts, n in self.faces:
            on = any(all(abs(p[axis] - value) < 1e-9 for p in pts) for axis, value in planes)
            if not on:
                keep.append((pts, n))
        return Solid(keep)


def box_solid(lo: Sequence[float], hi: Sequence[float]) -> Solid:
    """An axis-aligned box lo..hi with its 6 outward faces."""
    faces = []
    for _name, (axis, sign) in AXES.items():
        n = [0.0, 0.0, 0.0]
        n[axis] = sign
        value = hi[axis] if sign > 0 else lo[axis]
        faces.append((axis_rect(axis, value, lo, hi), (n[0], n[1], n[2])))
    return Solid(faces)


def wedge_solid(x0: float, x1: float, y0: float, y1: float, z0: float, rise: float) -> Solid:
    """The solid under a slope rising along +x from (x0, z0) to (x1, z0 + rise),
    with a vertical back face at x1 and a floor at z0 (y from y0 to y1)."""
    top = z0 + rise
    slope = [(x0, y0, z0), (x1, y0, top), (x1, y1, top), (x0, y1, z0)]
    slope_n = _unit((-rise, 0.0, x1 - x0))
    back = [(x1, y0, z0), (x1, y1, z0), (x1, y1, top), (x1, y0, top)]
    bottom = [(x0, y0, z0), (x1, y0, z0), (x1, y1, z0), (x0, y1, z0)]
    side0 = [(x0, y0, z0), (x1, y0, z0), (x1, y0, top)]
    side1 = [(x0, y1, z0), (x1, y1, z0), (x1, y1, top)]
    return Solid(
        [
            (slope, slope_n),
            (back, (1.0, 0.0, 0.0)),
            (bottom, (0.0, 0.0, -1.0)),
            (side0, (0.0, -1.0, 0.0)),
            (side1, (0.0, 1.0, 0.0)),
        ]
    )


# -- BSP assembly ---------------------------------------------------------------------------


def _leaf(poly_ids: Sequence[int], solid: bool) -> dict[str, Any]:
    return {"type": "LEAF", "solid": int(solid), "in_polys": list(poly_ids)}


def _node(plane: dict[str, Any], pos: dict[str, Any], neg: dict[str, Any]) -> dict[str, Any]:
    return {"type": "BPnN", "splitting_plane": plane, "pos_node": pos, "neg_node": neg}


def _flip(plane: dict[str, Any]) -> dict[str, Any]:
    return {"normal": [-c + 0.0 for c in plane["normal"]], "d": -plane["d"] + 0.0}


def _solid_chain(solid: Solid, solid_ids: list[int], empty_ids: list[int]) -> dict[str, Any]:
    """Outward planes: the positive side of each is outside the solid."""
    node = _leaf(solid_ids, True)
    for plane in reversed(solid.planes):
        node = _node(plane, _leaf(empty_ids, False), node)
    return node


def _separate(boxes: list[tuple[list[float], list[float]]]) -> tuple[int, float] | None:
    """An axis-aligned plane with every box on one side or the other, both sides used."""
    for axis in range(3):
        for c in sorted({b[0][axis] for b in boxes} | {b[1][axis] for b in boxes}):
            pos = [i for i, b in enumerate(boxes) if b[0][axis] >= c - 1e-9]
            neg = [i for i, b in enumerate(boxes) if b[1][axis] <= c + 1e-9 and i not in pos]
            if pos and neg and len(pos) + len(neg) == len(boxes):
                return axis, c
    return None


def union_bsp(solids: list[tuple[Solid, list[int]]], empty_ids: list[int]) -> dict[str, Any]:
    """A physics BSP (without spheres) for disjoint convex solids, each with the
    ids of its polygons; the empty regions list `empty_ids`."""
    if not solids:
        return _leaf(empty_ids, False)
    if len(solids) == 1:
        return _solid_chain(solids[0][0], solids[0][1], empty_ids)
    boxes = [s.bbox() for s, _ in solids]
    cut = _separate(boxes)
    if cut is None:
        raise ValueError("solids cannot be split apart by an axis-aligned plane")
    axis, c = cut
    pos = [s for s, b in zip(solids, boxes) if b[0][axis] >= c - 1e-9]
    neg = [s for s, b in zip(solids, boxes) if not b[0][axis] >= c - 1e-9]
    n = [0.0, 0.0, 0.0]
    n[axis] = 1.0
    return _node({"normal": n, "d": -c + 0.0}, union_bsp(pos, empty_ids), union_bsp(neg, empty_ids))


def finish_physics_bsp(root: dict[str, Any], mesh: Mesh) -> dict[str, Any]:
    """Give every node its bounding sphere (of the polygons listed below it; an
    empty leaf takes its parent's) and number the leaves, positive side first."""

    def points(node: dict[str, Any]) -> list[Point]:
        if node["type"] == "LEAF":
            pts = [p for pid in node["in_polys"] for p in mesh.points_of(pid)]
        else:
            pts = points(node["pos_node"]) + points(node["neg_node"])
        if pts:
            node["sphere"] = _sphere_of(pts)
        return pts

    if not points(root):
        raise ValueError("a physics BSP needs at least one polygon")
    counter = [0]

    def fill(node: dict[str, Any], parent_sphere: dict[str, Any]) -> None:
        node.setdefault("sphere", parent_sphere)
        if node["type"] == "LEAF":
            node["leaf_index"] = counter[0]
            counter[0] += 1
            return
        fill(node["pos_node"], node["sphere"])
        fill(node["neg_node"], node["sphere"])

    fill(root, root["sphere"])
    return root


def count_leaves(node: dict[str, Any]) -> int:
    if node["type"] == "LEAF":
        return 1
    return sum(count_leaves(node[k]) for k in ("pos_node", "neg_node") if k in node)


def cell_bsp(planes: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """A cell BSP: the intersection of the positive half-spaces of `planes`."""
    node: dict[str, Any] = {"type": "LEAF", "leaf_index": 0}
    for plane in reversed(planes):
        node = {"type": "BPnn", "splitting_plane": plane, "pos_node": node}
    return node


# -- cells ------------------------------------------------------------------------------------


@dataclass
class Face:
    """One bounding plane of a convex cell: `plane` faces into the cell; `walls`
    are its physics polygons; `portal` the opening's polygon (if any)."""

    plane: dict[str, Any]
    walls: list[list[Point]] = field(default_factory=list)
    portal: list[Point] | None = None


@dataclass
class Struct:
    """A built CellStruct: the scene dict and what its cells need to know."""

    data: dict[str, Any]
    portal_polys: list[int]  # polygon ids, in `portals` order
    mesh: Mesh


def convex_struct(faces: Sequence[Face], solids: Sequence[Solid] = ()) -> Struct:
    """A CellStruct for a convex cell with optional solids inside it."""
    mesh = Mesh()
    chain: list[tuple[dict[str, Any], list[int], bool]] = []
    portals: list[int] = []
    all_ids: list[int] = []
    for f in faces:
        inward = f.plane["normal"]
        ids = [mesh.physics_poly(w, inward) for w in f.walls]
        all_ids += ids
        if f.portal is not None:
            portals.append(mesh.drawing_poly(f.portal, [-c for c in inward]))  # faces the other cell
        if ids:
            chain.append((f.plane, ids, f.portal is None))
    inner_solids = []
    for s in solids:
        inner_solids.append((s, [mesh.physics_poly(pts, n) for pts, n in s.faces]))
    node = union_bsp(inner_solids, all_ids)
    for plane, ids, solid in reversed(chain):
        node = _node(plane, node, _leaf(ids, solid))
    physics = finish_physics_bsp(node, mesh)
    data = {
        "vertices": mesh.vertices_dict(),
        "polygons": mesh.drawing_dict(),
        "portals": portals,
        "cell_bsp": cell_bsp([f.plane for f in faces]),
        "physics_polygons": mesh.physics_dict(),
        "physics_bsp": physics,
    }
    return Struct(data, portals, mesh)


@dataclass(frozen=True)
class Door:
    """An opening in one wall of a box room: `wall` is "-x", "+x", "-y" or "+y";
    it spans `lo..hi` along the wall's horizontal axis and from `sill` (None:
    the floor) up to `top` (None: the ceiling)."""

    wall: str
    lo: float
    hi: float
    top: float | None = None
    sill: float | None = None


def room_faces(lo: Point, hi: Point, doors: Sequence[Door] = ()) -> list[Face]:
    """The 6 inner faces of the box lo..hi, walls split around their doors
    (the strip above the door across the whole wall, then the parts left and
    right of it). Faces come in the order of the shared scenes' rooms (floor,
    east, ceiling, west, south, north), which is also the order of their
    physics polygons (a face's walls, then its portal)."""
    faces = []
    for name in FACE_ORDER:
        axis, sign = AXES[name]
        value = hi[axis] if sign > 0 else lo[axis]
        inward = [0.0, 0.0, 0.0]
        inward[axis] = -sign
        plane = {"normal": inward, "d": sign * value + 0.0}  # -sign * x + sign * value >= 0 inside
        door = next((d for d in doors if d.wall == name), None)
        if door is None:
            faces.append(Face(plane, [axis_rect(axis, value, lo, hi)]))
            continue
        if axis == 2:
            raise ValueError("doors go in walls, not floors or ceilings")
        u = 1 - axis  # the wall's horizontal axis
        top = hi[2] if door.top is None else door.top
        sill = lo[2] if door.sill is None else door.sill
        walls = []

        def rect(ulo: float, uhi: float, zlo: float, zhi: float) -> None:
            if uhi - ulo > 1e-9 and zhi - zlo > 1e-9:
                a = [0.0, 0.0, 0.0]
                b = [0.0, 0.0, 0.0]
                a[u], a[2], b[u], b[2] = ulo, zlo, uhi, zhi  # noqa: B023 - called at once, in this iteration
                walls.append(axis_rect(axis, value, a, b))  # noqa: B023

        rect(lo[u], hi[u], top, hi[2])
        rect(lo[u], door.lo, sill, top)
        rect(door.hi, hi[u], sill, top)
        rect(lo[u], hi[u], lo[2], sill)
        a = [0.0, 0.0, 0.0]
        b = [0.0, 0.0, 0.0]
        a[u], a[2], b[u], b[2] = door.lo, sill, door.hi, top
        faces.append(Face(plane, walls, axis_rect(axis, value, a, b)))
    return faces


def room_struct(lo: Point, hi: Point, doors: Sequence[Door] = (), solids: Sequence[Solid] = ()) -> Struct:
    """An axis-aligned box room (cell-local lo..hi) with doorways and convex
    solids inside it. Solid faces lying on the room's walls, floor or ceiling
    are left out (the room's own faces are there)."""
    bounds = [(a, v) for a in range(3) for v in (lo[a], hi[a])]
    return convex_struct(room_faces(lo, hi, doors), [s.without_faces_on(bounds) for s in solids])


def ramp_struct(
    x0: float, x1: float, y0: float, y1: float, z0: float, z1: float, height: float, end_height: float | None = None
) -> Struct:
    """A corridor cell whose floor slopes from z0 at x = x0 to z1 at x = x1 (y
    from y0 to y1), its ceiling `height` above the floor at x0 and
    `end_height` (default: the same) at x1, both ends open
    (portal 0 at x1, portal 1 at x0: faces in the order floor, east end,
    ceiling, west end, south, north, as the shared cellar's ramp)."""
    a0, a1 = (x0, y0, z0), (x1, y0, z1)
    b0, b1 = (x0, y1, z0), (x1, y1, z1)
    h1 = height if end_height is None else end_height

    def lift(p: Point) -> Point:
        return (p[0], p[1], p[2] + (height if p[0] == x0 else h1))

    floor = [a0, a1, b1, b0]
    ceiling = [lift(p) for p in floor]
    floor_n = _unit((-(z1 - z0), 0.0, x1 - x0))
    ceiling_n = _unit(((z1 + h1) - (z0 + height), 0.0, -(x1 - x0)))
    faces = [
        Face(plane_of(floor, floor_n), [floor]),
        Face(plane_of([a1, b1, lift(b1), lift(a1)], (-1.0, 0.0, 0.0)), [], [a1, b1, lift(b1), lift(a1)]),
        Face(plane_of(ceiling, ceiling_n), [ceiling]),
        Face(plane_of([a0, b0, lift(b0), lift(a0)], (1.0, 0.0, 0.0)), [], [a0, b0, lift(b0), lift(a0)]),
        Face(plane_of([a0, a1, lift(a1), lift(a0)], (0.0, 1.0, 0.0)), [[a0, a1, lift(a1), lift(a0)]]),
        Face(plane_of([b0, b1, lift(b1), lift(b0)], (0.0, -1.0, 0.0)), [[b0, b1, lift(b1), lift(b0)]]),
    ]
    return convex_struct(faces)


# -- GfxObjs ------------------------------------------------------------------------------------


def gfx_obj(solids: Sequence[Solid]) -> dict[str, Any]:
    """A GfxObj whose physics shape is the union of disjoint convex solids."""
    mesh = Mesh()
    parts = [(s, [mesh.physics_poly(pts, n) for pts, n in s.faces]) for s in solids]
    bsp = finish_physics_bsp(union_bsp(parts, []), mesh)
    pts = list(mesh.vertices.values())
    return {
        "vertices": mesh.vertices_dict(),
        "physics_polygons": mesh.physics_dict(),
        "physics_bsp": bsp,
        "num_physics_leaves": count_leaves(bsp),
        "sort_center": _sphere_of(pts)["origin"],
    }


def shell_boxes(lo: Point, hi: Point, thickness: float = 0.25, door: Door | None = None) -> list[Solid]:
    """The walls and flat roof of a building around the room lo..hi (walls
    `thickness` thick outside it, the roof on top), with a gap for `door`."""
    t = thickness
    lx, ly, lz = lo
    hx, hy, hz = hi
    boxes: list[tuple[Point, Point]] = [
        ((lx - t, ly - t, hz), (hx + t, hy + t, hz + t)),  # roof
    ]
    walls = {
        "+y": ((lx - t, hy, lz), (hx + t, hy + t, hz)),
        "-y": ((lx - t, ly - t, lz), (hx + t, ly, hz)),
        "+x": ((hx, ly, lz), (hx + t, hy, hz)),
        "-x": ((lx - t, ly, lz), (lx, hy, hz)),
    }
    for name, (a, b) in walls.items():
        if door is None or door.wall != name:
            boxes.append((a, b))
            continue
        axis = AXES[name][0]
        u = 1 - axis
        top = hz if door.top is None else door.top
        for ulo, uhi, zlo, zhi in ((a[u], door.lo, lz, hz), (door.hi, b[u], lz, hz), (door.lo, door.hi, top, hz)):
            if uhi - ulo > 1e-9 and zhi - zlo > 1e-9:
                p, q = list(a), list(b)
                p[u], q[u], p[2], q[2] = ulo, uhi, zlo, zhi
                boxes.append(((p[0], p[1], p[2]), (q[0], q[1], q[2])))
    return [box_solid(a, b) for a, b in boxes]


# -- scenes -----------------------------------------------------------------------------------------


def _frame(origin: Sequence[float], orientation: Sequence[float] = IDENTITY) -> dict[str, Any]:
    return {"origin": [float(c) for c in origin], "orientation": [float(c) for c in orientation]}


class SceneBuilder:
    """One landblock (flat ground at `GROUND`) and the indoor things on it.

    Coordinates given to `add_env_cell`, `add_building` and `add_object` are
    landblock coordinates (x, y in 0..192, z absolute)."""

    def __init__(self, landblock: int = LANDBLOCK, ground_byte: int = GROUND_BYTE, name: str = "indoor-synthetic") -> None:
        self.landblock = landblock
        self.ground_byte = ground_byte
        self.name = name
        self.cell_structs: dict[str, Any] = {}
        self.gfx_objs: dict[str, Any] = {}
        self.env_cells: list[dict[str, Any]] = []
        self.buildings: list[dict[str, Any]] = []
        self.objects: list[dict[str, Any]] = []
        self.structs: dict[int, Struct] = {}

    # ids
    def cell_id(self, index: int) -> int:
        return (self.landblock << 16) | index

    def outdoor_cell(self, x: float, y: float) -> int:
        return (self.landblock << 16) | (int(x // 24) * 8 + int(y // 24) + 1)

    # portal.dat things
    def add_struct(self, struct: Struct) -> int:
        index = len(self.cell_structs)
        self.cell_structs[str(index)] = struct.data
        self.structs[index] = struct
        return index

    def add_gfx_obj(self, gfx: dict[str, Any]) -> int:
        gid = 0x01000001 + len(self.gfx_objs)
        self.gfx_objs[f"{gid:08X}"] = gfx
        return gid

    # cell.dat things
    def add_env_cell(
        self,
        struct_index: int,
        origin: Sequence[float],
        portals: Sequence[tuple[int, int]] = (),
        orientation: Sequence[float] = IDENTITY,
        seen_outside: bool | None = None,
        static_objects: Sequence[tuple[int, Sequence[float]]] = (),
    ) -> int:
        """An EnvCell of cell struct `struct_index`; `portals` pairs, in the cell
        struct's portal order, (other cell id, other portal index) with other
        cell id 0xFFFF (and any index) for the outside. Cells are numbered
        0x0100, 0x0101, ... in the order they are added; a portal may name a
        cell added later. `static_objects`: (GfxObj id, landblock origin)."""
        index = 0x100 + len(self.env_cells)
        struct = self.structs[struct_index]
        if len(portals) != len(struct.portal_polys):
            raise ValueError(f"cell struct {struct_index} has {len(struct.portal_polys)} portals, got {len(portals)}")
        cell_portals = []
        visible = [index]
        for poly, (other, other_portal) in zip(struct.portal_polys, portals):
            other &= 0xFFFF
            cell_portals.append(
                {
                    "flags": 0,
                    "polygon_id": poly,
                    "other_cell_id": f"{other:04X}",
                    "other_portal_id": 65535 if other == 0xFFFF else other_portal,
                }
            )
            if other != 0xFFFF and other not in visible:
                visible.append(other)
        outside = any((o & 0xFFFF) == 0xFFFF for o, _ in portals) if seen_outside is None else seen_outside
        self.env_cells.append(
            {
                "id": f"{self.cell_id(index):08X}",
                "environment_id": f"{ENV_ID:08X}",
                "cell_structure": struct_index,
                "position": _frame(origin, orientation),
                "cell_portals": cell_portals,
                "visible_cells": [f"{v:04X}" for v in sorted(visible)],
                "seen_outside": outside,
                "static_objects": [{"id": f"{gid:08X}", "frame": _frame(o)} for gid, o in static_objects],
                "restriction_obj": 0,
            }
        )
        return self.cell_id(index)

    def add_building(
        self, model_id: int, origin: Sequence[float], doors: Sequence[tuple[int, int]] = (), orientation: Sequence[float] = IDENTITY
    ) -> None:
        """A building (its shell GfxObj) with doors: (EnvCell id, portal index
        of that cell's portal to the outside)."""
        gfx = self.gfx_objs[f"{model_id:08X}"]
        self.buildings.append(
            {
                "model_id": f"{model_id:08X}",
                "frame": _frame(origin, orientation),
                "num_leaves": gfx["num_physics_leaves"],
                "portals": [
                    {"flags": 0, "other_cell_id": f"{cell & 0xFFFF:04X}", "other_portal_id": portal, "stab_list": [f"{cell & 0xFFFF:04X}"]}
                    for cell, portal in doors
                ],
            }
        )

    def add_object(self, model_id: int, origin: Sequence[float], orientation: Sequence[float] = IDENTITY) -> None:
        """A static object (LandblockInfo Objects) at a landblock position."""
        self.objects.append({"id": f"{model_id:08X}", "frame": _frame(origin, orientation)})

    # output
    def scene(self) -> dict[str, Any]:
        lb: dict[str, Any] = {"id": f"{self.landblock:04X}", "heights": [self.ground_byte] * 81}
        if self.env_cells:
            lb["env_cells"] = self.env_cells
        if self.buildings:
            lb["buildings"] = self.buildings
        if self.objects:
            lb["objects"] = self.objects
        scene: dict[str, Any] = {"format": "acphys-scene/1", "name": self.name, "height_table": HEIGHT_TABLE, "landblocks": [lb]}
        if self.cell_structs:
            scene["environments"] = {f"{ENV_ID:08X}": {"cell_structs": self.cell_structs}}
        if self.gfx_objs:
            scene["gfx_objs"] = self.gfx_objs
        return scene

    def world(self, settings: engine.EngineSettings = engine.RETAIL) -> engine.World:
        return engine.world_from_scene_dict(self.scene(), settings=settings)
