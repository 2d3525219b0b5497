"""Where a navigation graph's nodes may go: candidate points on walkable surfaces, per cell.

A node is a point where the walker, placed there (the client's placement,
no sliding), stands on walkable ground in the cell the sample was drawn
for. The candidates, for a walker class and a lattice spacing:

- an outdoor cell: the lattice points inside it, on the terrain and, where
  a building or an object stands in the cell, on its walkable polygons (a
  roof, a platform, a step: each also at its centroid); and both sides of each door of a
  building attached to the cell;
- an indoor cell (EnvCell): the lattice points inside each of its walkable
  physics polygons (floors, stair treads, ramps: normal z at least FloorZ)
  and along each such polygon's middle line (_spine), so that a corridor or
  a tread narrower than the lattice still gets nodes; and both sides of
  each of its portals.

Doors and portals get nodes of their own because a door is usually
narrower than the lattice spacing: no lattice point need lie in it.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import TYPE_CHECKING, Final

from ..constants import BLOCK_LENGTH, CELL_LENGTH, FLOOR_Z
from ..geometry import Vec3
from ..cells.env_cell import OUTSIDE_CELL, EnvCell

if TYPE_CHECKING:
    from ..cells.land_cell import LandCell
    from ..world.landblock import Landblock
    from ..world.world import World

__all__ = ["lattice", "outdoor_candidates", "indoor_candidates", "env_cell_box", "portal_points"]

#: a portal node stands this far (beyond the walker's radius) from the portal's plane
_PORTAL_CLEARANCE: Final = 0.35


def lattice(lo: float, hi: float, spacing: float) -> Iterator[float]:
    """The global lattice coordinates (i + 1/2) * spacing in [lo, hi)."""
    i = math.ceil(lo / spacing - 0.5)
    while (i + 0.5) * spacing < hi:
        yield (i + 0.5) * spacing
        i += 1


def block_xy(cell_id: int) -> tuple[float, float]:
    """The global coordinates of the south-west corner of a cell id's landblock."""
    return ((cell_id >> 24) & 0xFF) * BLOCK_LENGTH, ((cell_id >> 16) & 0xFF) * BLOCK_LENGTH


def outdoor_candidates(world: World, landblock: Landblock, cell: LandCell, spacing: float,
                       radius: float) -> list[tuple[int, float, float, float]]:
    """(cell id, local x, y, z) candidates of an outdoor cell."""
    index = (cell.id & 0xFFFF) - 1
    x0, y0 = (index // 8) * CELL_LENGTH, (index % 8) * CELL_LENGTH
    bx, by = block_xy(cell.id)
    tops = _object_tops(cell)
    out: list[tuple[int, float, float, float]] = []
    for gx in lattice(bx + x0, bx + x0 + CELL_LENGTH, spacing):
        for gy in lattice(by + y0, by + y0 + CELL_LENGTH, spacing):
            x, y = gx - bx, gy - by
            z = landblock.terrain.height_at(x, y)
            triangle = cell.find_terrain_poly(Vec3(x, y, z), False)
            out.append((cell.id, x, y, z + clearance(triangle.plane.normal.z if triangle is not None else 1.0, radius)))
            for loop in tops:
                if _inside_2d(loop, x, y):
                    top = _height_on(loop, x, y)
                    if top > z + 0.05:
                        out.append((cell.id, x, y, top + clearance(_normal_z(loop), radius)))
    for loop in tops:  # a top narrower than the lattice still gets nodes
        for x, y in _spine(loop, spacing):
            if x0 <= x < x0 + CELL_LENGTH and y0 <= y < y0 + CELL_LENGTH:
                out.append((cell.id, x, y, _height_on(loop, x, y) + clearance(_normal_z(loop), radius)))
    building = cell.building
    if building is not None:
        block = cell.id & 0xFFFF0000
        for door in building.portals:
            env = world.get_landcell(block | door.other_cell_id)
            if isinstance(env, EnvCell) and 0 <= door.other_portal_id < len(env.portals):
                for px, py, pz in portal_points(env, door.other_portal_id, radius):
                    if 0.0 <= px < BLOCK_LENGTH and 0.0 <= py < BLOCK_LENGTH:
                        out.append((cell.id, px, py, landblock.terrain.height_at(px, py) if pz is None else pz))
    return out


def _object_tops(cell: LandCell) -> list[list[Vec3]]:
    """The walkable physics polygons (landblock coordinates) of what stands in an outdoor cell: its
    building's shell and the static objects whose shadows reach into it (a roof, a platform, a step)."""
    parts = list(cell.building.parts) if cell.building is not None else []
    for obstacle in cell.shadow_objects:
        if obstacle.owner is None:  # (a mover is never ground a node is sampled on)
            obstacle.place_parts()
            parts.extend(obstacle.parts)
    loops: list[list[Vec3]] = []
    for part in parts:
        bsp = part.gfx_obj.physics_bsp
        if bsp is None:
            continue
        frame = part.pos.frame
        scale = part.gfx_scale
        seen: set[int] = set()
        for node in bsp.root_node.iter_nodes():
            for polygon in node.polygons:
                if id(polygon) in seen:
                    continue
                seen.add(id(polygon))
                if frame.local_to_global_vec(polygon.plane.normal).z >= FLOOR_Z:
                    loops.append([frame.local_to_global(Vec3(v.x * scale.x, v.y * scale.y, v.z * scale.z)) for v in polygon.vertices])
    return loops


def _walkable_floors(env: EnvCell) -> Iterator[list[Vec3]]:
    """The walkable physics polygons of an EnvCell, as vertex loops in landblock coordinates."""
    frame = env.pos.frame
    for polygon in env.cell_struct.physics_polygons.values():
        normal = frame.local_to_global_vec(polygon.plane.normal)
        if normal.z >= FLOOR_Z:
            yield [frame.local_to_global(v) for v in polygon.vertices]


def _inside_2d(loop: list[Vec3], x: float, y: float) -> bool:
    """(x, y) inside a convex loop, either winding, edges included."""
    sign = 0.0
    n = len(loop)
    for i in range(n):
        a, b = loop[i], loop[(i + 1) % n]
        cross = (b.x - a.x) * (y - a.y) - (b.y - a.y) * (x - a.x)
        if cross == 0.0:
            continue
        if sign == 0.0:
            sign = cross
        elif (cross > 0.0) != (sign > 0.0):
            return False
    return True


def clearance(normal_z: float, radius: float) -> float:
    """How far above a surface of this slope a sphere of `radius`, standing on it at a point, must be
    placed so as not to cut into it (its centre is radius / normal_z above the surface there, not
    radius), and a centimetre more: a placement that may not slide refuses an overlap, and lands an
    object a little above the ground onto it."""
    return radius * (1.0 / max(normal_z, 0.1) - 1.0) + 0.01


def _normal_z(loop: list[Vec3]) -> float:
    a, b, c = loop[0], loop[1], loop[2]
    n = (b - a).cross(c - a)
    length = n.length()
    return abs(n.z) / length if length > 0.0 else 1.0


def _spine(loop: list[Vec3], spacing: float) -> list[tuple[float, float]]:
    """Points along a polygon's middle: its centroid, and every half spacing along the line through the
    centroid parallel to its longer side (x or y) while inside it. A corridor, a ramp or a tread
    narrower than the lattice, which lattice points miss or meet at its walls, gets nodes down its
    middle."""
    cx = sum(v.x for v in loop) / len(loop)
    cy = sum(v.y for v in loop) / len(loop)
    along_x = max(v.x for v in loop) - min(v.x for v in loop) >= max(v.y for v in loop) - min(v.y for v in loop)
    out = [(cx, cy)]
    step = 0.5 * spacing
    for sign in (1.0, -1.0):
        k = 1
        while k < 10_000:
            x, y = (cx + sign * k * step, cy) if along_x else (cx, cy + sign * k * step)
            if not _inside_2d(loop, x, y):
                break
            out.append((x, y))
            k += 1
    return out


def _height_on(loop: list[Vec3], x: float, y: float) -> float:
    """The height of a polygon's plane at (x, y)."""
    a, b, c = loop[0], loop[1], loop[2]
    n = (b - a).cross(c - a)
    if abs(n.z) < 1e-9:
        return max(v.z for v in loop)
    return a.z - (n.x * (x - a.x) + n.y * (y - a.y)) / n.z


def indoor_candidates(env: EnvCell, spacing: float, radius: float) -> list[tuple[int, float, float, float]]:
    """(cell id, local x, y, z) candidates of an EnvCell."""
    bx, by = block_xy(env.id)
    out: list[tuple[int, float, float, float]] = []
    for loop in _walkable_floors(env):
        xs = [v.x for v in loop]
        ys = [v.y for v in loop]
        lift = clearance(_normal_z(loop), radius)
        for gx in lattice(bx + min(xs), bx + max(xs), spacing):
            for gy in lattice(by + min(ys), by + max(ys), spacing):
                x, y = gx - bx, gy - by
                if _inside_2d(loop, x, y):
                    out.append((env.id, x, y, _height_on(loop, x, y) + lift))
        for x, y in _spine(loop, spacing):
            out.append((env.id, x, y, _height_on(loop, x, y) + lift))
    for portal_index in range(len(env.portals)):
        for x, y, z in portal_points(env, portal_index, radius):
            if z is not None:
                out.append((env.id, x, y, z))
    return out


def portal_points(env: EnvCell, portal_index: int, radius: float) -> list[tuple[float, float, float | None]]:
    """Points on both sides of an EnvCell's portal, on its floor line, clear of its plane by the walker's
    radius: landblock coordinates; z None on a side that opens to the outside (the terrain decides)."""
    portal = env.portals[portal_index]
    polygon = env.cell_struct.polygons.get(portal.polygon_id)
    if polygon is None:
        return []
    frame = env.pos.frame
    loop = [frame.local_to_global(v) for v in polygon.vertices]
    normal = frame.local_to_global_vec(polygon.plane.normal)
    flat = Vec3(normal.x, normal.y, 0.0)
    length = flat.length()
    if length < 0.5:
        return []  # a floor or ceiling portal (a hatch): not walked through
    flat = flat * (1.0 / length)
    bottom = min(v.z for v in loop)
    cx = sum(v.x for v in loop) / len(loop)
    cy = sum(v.y for v in loop) / len(loop)
    # the other cell lies in front of the polygon when the PortalSide flag is clear
    toward_other = flat if portal.portal_side else flat * -1.0
    out: list[tuple[float, float, float | None]] = []
    clear = radius + _PORTAL_CLEARANCE
    for side, distance in ((1.0, clear), (-1.0, clear), (0.0, 0.0)):
        x = cx + toward_other.x * side * distance
        y = cy + toward_other.y * side * distance
        outside = side > 0.0 and portal.other_cell_id == OUTSIDE_CELL
        out.append((x, y, None if outside else bottom))
    return out


def env_cell_box(env: EnvCell) -> tuple[float, float, float, float, float, float]:
    """An EnvCell's extent in global x, y and absolute z: (x0, x1, y0, y1, z0, z1)."""
    frame = env.pos.frame
    bx, by = block_xy(env.id)
    points = [frame.local_to_global(v) for p in env.cell_struct.physics_polygons.values() for v in p.vertices]
    if not points:
        o = env.pos.frame.origin
        points = [o]
    return (bx + min(p.x for p in points), bx + max(p.x for p in points),
            by + min(p.y for p in points), by + max(p.y for p in points),
            min(p.z for p in points), max(p.z for p in points))
