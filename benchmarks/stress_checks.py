"""What the stability stress run (benchmarks/stress.py) checks after every move, measured
independently of the engine: finite results, how far the spheres sink below the terrain, reach into
an EnvCell's walls or into sphere objects.
"""

from __future__ import annotations

import math
from typing import Any

import engine
from engine import Vec3
from engine.terrain.water import ENTIRELY_WATER_DEPTH

from . import scenes as S

__all__ = ["nonfinite", "sphere_centres", "terrain_below", "CellPolys", "penetrates_polygon", "wall_depth",
           "in_block", "object_depth", "crowd_spheres", "inside_polygon"]


def _finite_vec(v: Any) -> bool:
    return v is None or (math.isfinite(v.x) and math.isfinite(v.y) and math.isfinite(v.z))


def nonfinite(r: engine.MoveResult) -> bool:
    f = r.position.frame
    q = f.orientation
    if not _finite_vec(f.origin) or not all(math.isfinite(c) for c in (q.w, q.x, q.y, q.z)):
        return True
    if r.contact_plane is not None and (not _finite_vec(r.contact_plane.normal) or not math.isfinite(r.contact_plane.d)):
        return True
    return not (_finite_vec(r.collision_normal) and _finite_vec(r.sliding_normal))


def sphere_centres(world: engine.World, mid: int) -> list[tuple[Vec3, float]]:
    m = world.mover(mid)
    f = m.position.frame
    return [(f.local_to_global(s.center * m.scale), s.radius * m.scale) for s in m.spheres]


def terrain_below(world: engine.World, cell_id: int, p: Vec3) -> tuple[float, float] | None:
    """(terrain height, how far a sphere may legitimately sink below it) under
    landblock-local point p of cell_id's landblock, from whichever loaded
    landblock holds it; None off the loaded terrain. Water lets a sphere sink
    by the cell's water depth (measured along the terrain normal)."""
    bx, by = (cell_id >> 24) & 0xFF, (cell_id >> 16) & 0xFF
    gx, gy = bx * 192.0 + p.x, by * 192.0 + p.y
    nbx, nby = int(gx // 192.0), int(gy // 192.0)
    lb = world.landblocks.get((nbx << 8) | nby) if 0 <= nbx <= 0xFF and 0 <= nby <= 0xFF else None
    if lb is None:
        return None
    lx, ly = min(max(gx - nbx * 192.0, 0.0), 191.999), min(max(gy - nby * 192.0, 0.0), 191.999)
    h = lb.terrain.height_at(lx, ly)
    cell_id2 = ((nbx << 24) | (nby << 16)) + int(lx // 24) * 8 + int(ly // 24) + 1
    cell = lb.get_cell(cell_id2)
    wt = getattr(cell, "water_type", 0)
    if not wt:
        return h, 0.0
    depth = ENTIRELY_WATER_DEPTH if wt == 2 else lb.calc_water_depth(cell_id2, Vec3(lx, ly, h))
    nz = max(0.05, lb.terrain.normal_at(lx, ly).z)
    return h, depth / nz


class CellPolys:
    """Physics polygons of EnvCells in landblock coordinates, cached by cell id."""

    def __init__(self, world: engine.World) -> None:
        self.world = world
        self.cache: dict[int, list[tuple[Vec3, float, list[Vec3], Vec3, float]]] = {}
        self.near_cache: dict[int, list[tuple[Vec3, float, list[Vec3], Vec3, float]]] = {}

    def near(self, cell_id: int) -> list[tuple[Vec3, float, list[Vec3], Vec3, float]]:
        """The cell's polygons and those of the EnvCells behind its portals."""
        got = self.near_cache.get(cell_id)
        if got is None:
            got = list(self.get(cell_id))
            cell = self.world.get_landcell(cell_id)
            for portal in getattr(cell, "portals", []):
                if portal.other_cell_id != 0xFFFF:
                    got += self.get((cell_id & 0xFFFF0000) | portal.other_cell_id)
            self.near_cache[cell_id] = got
        return got

    def get(self, cell_id: int) -> list[tuple[Vec3, float, list[Vec3], Vec3, float]]:
        got = self.cache.get(cell_id)
        if got is not None:
            return got
        out = []
        cell = self.world.get_landcell(cell_id)
        cs = getattr(cell, "cell_struct", None)
        if cs is not None and cell is not None:
            f = cell.pos.frame
            for poly in cs.physics_polygons.values():
                vs = [f.local_to_global(v) for v in poly.vertices]
                n = f.local_to_global_vec(poly.plane.normal)
                if len(vs) < 3 or n.length() < 0.5:
                    continue
                d = -n.dot(vs[0])
                c = Vec3(sum(v.x for v in vs) / len(vs), sum(v.y for v in vs) / len(vs), sum(v.z for v in vs) / len(vs))
                rad = max((v - c).length() for v in vs)
                out.append((n, d, vs, c, rad))
        self.cache[cell_id] = out
        return out


def penetrates_polygon(centre: Vec3, r: float, n: Vec3, d: float, vs: list[Vec3]) -> float:
    """How far (m) a sphere crosses a polygon's plane (r - |distance|; 0 when it does not),
    counting only when the centre projects inside the polygon. Either side counts the same,
    so a sphere resting against one face of a zero-thickness wall (two coplanar polygons
    back to back) reaches 0 into the other."""
    dist = n.dot(centre) + d
    if dist >= r or dist <= -r:
        return 0.0
    last = vs[-1]
    sign = 0
    for v in vs:
        k = (v - last).cross(centre - last).dot(n)
        s = 1 if k > 1e-12 else (-1 if k < -1e-12 else 0)
        if s:
            if sign and s != sign:
                return 0.0
            sign = s
        last = v
    return r - abs(dist)


def wall_depth(polys: CellPolys, cell_id: int, centres: list[tuple[Vec3, float]]) -> float:
    """How far the spheres reach into the walls of an EnvCell and of the cells behind its portals."""
    if (cell_id & 0xFFFF) < 0x100:
        return 0.0
    worst = 0.0
    for c, rad in centres:
        for n, d, vs, pc, prad in polys.near(cell_id):
            if (c - pc).length() <= rad + prad:
                worst = max(worst, penetrates_polygon(c, rad, n, d, vs))
    return worst


def in_block(centres: list[tuple[Vec3, float]], cell_id: int, home: int) -> list[tuple[Vec3, float]]:
    """Sphere centres given in cell_id's landblock frame, in landblock `home`'s frame."""
    dx = (((cell_id >> 24) & 0xFF) - ((home >> 8) & 0xFF)) * 192.0
    dy = (((cell_id >> 16) & 0xFF) - (home & 0xFF)) * 192.0
    if dx == 0.0 and dy == 0.0:
        return centres
    return [(c + Vec3(dx, dy, 0.0), r) for c, r in centres]


def object_depth(objects: list[tuple[Vec3, float]], centres: list[tuple[Vec3, float]]) -> float:
    """How far the spheres reach into the sphere objects (both in the same landblock frame)."""
    worst = 0.0
    for c, rad in centres:
        for oc, orad in objects:
            worst = max(worst, (rad + orad) - (c - oc).length())
    return worst


def crowd_spheres() -> list[tuple[Vec3, float]]:
    """The crowd's spheres (centre in landblock A9B4's frame, radius), as scenes.crowd_scene places them."""
    out = []
    for obj in S.crowd_scene()["landblocks"][4]["objects"]:
        x, y, z = obj["frame"]["origin"]
        out.append((Vec3(x, y, z + 0.5), 0.5))
    return out


def inside_polygon(p: Vec3, n: Vec3, vs: list[Vec3]) -> bool:
    """Does point p, on the plane of normal n, project inside the convex polygon vs?"""
    last, sign = vs[-1], 0
    for v in vs:
        k = (v - last).cross(p - last).dot(n)
        s = 1 if k > 1e-9 else (-1 if k < -1e-9 else 0)
        if s:
            if sign and s != sign:
                return False
            sign = s
        last = v
    return True
