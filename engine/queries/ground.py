"""ground: the surface under a point, outdoors the terrain, indoors the floor.

Outdoors the surface is the terrain triangle under the point's x, y, the one
the client's LandCell.find_terrain_poly gives a walkable search, with the
cell's water depth there (ObjCell.get_water_depth). Indoors (an EnvCell) it
is what a small probe sphere swept straight down from the point first rests
on, found by the client's transition as a missile's sweep is (the floor
polygon, a step, a static object standing there), found to within half a
millimetre by finer probes; its plane is extended to the point's x, y for
the height.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Final

from .. import limits
from ..cells.land_cell import LandCell
from ..constants import FLOOR_Z
from ..errors import OutOfRangeError, UnknownCellError
from ..geometry import Plane, Position, Vec3
from .results import Ground
from .sweep import _ray_checked, cell_for, check_point

if TYPE_CHECKING:
    from ..cells.obj_cell import ObjCell
    from ..world.world import World

__all__ = ["ground", "GROUND_PROBE_RADIUS", "MAX_GROUND_DROP"]

#: the indoor probe sphere's radius
GROUND_PROBE_RADIUS: Final = 0.05
#: the finer probes that find the contact to within half a millimetre
_REFINE_RADII: Final = (0.005, 0.0005)
#: how far below an indoor point the floor is looked for, by default
MAX_GROUND_DROP: Final = 50.0


def ground(world: World, position: Position, max_drop: float = MAX_GROUND_DROP, cache: dict[int, ObjCell | None] | None = None) -> Ground | None:
    """The surface under `position`, or None when an indoor point has no
    surface within `max_drop` metres below it."""
    check_point(world, position, "position")
    drop = limits.check_number(max_drop, "max_drop")
    if not drop > 0.0:
        raise OutOfRangeError(f"max_drop must be above 0 m, got {max_drop!r}")
    return _ground_checked(world, position, drop, cache)


def _ground_checked(world: World, position: Position, drop: float, cache: dict[int, ObjCell | None] | None) -> Ground | None:
    cell, home = cell_for(world, position, cache)
    if cell is None:
        raise UnknownCellError(f"no cell under {position!r} in the loaded world")
    o = home.frame.origin
    if (home.cell_id & 0xFFFF) < 0x100:
        assert isinstance(cell, LandCell)  # an outdoor id names a LandCell
        tri = cell.find_terrain_poly(o, False)
        if tri is None:  # on the cell's edge against float rounding: the next cell owns it
            raise UnknownCellError(f"no terrain triangle under {position!r}")
        plane = tri.plane
        z = tri.height_at(o.x, o.y)
        return Ground(z, plane, home.cell_id, plane.normal.z >= FLOOR_Z, cell.get_water_depth(Vec3(o.x, o.y, z)))
    # the probe starts with its bottom just above the point, so a point on the floor finds that floor
    r = GROUND_PROBE_RADIUS
    start = Position(home.cell_id, home.frame.with_origin(Vec3(o.x, o.y, o.z + r + 0.01)))
    end = Position(home.cell_id, home.frame.with_origin(Vec3(o.x, o.y, o.z - drop)))
    hit = _ray_checked(world, start, end, r, 0, cache)
    if not hit.hit or hit.normal is None or hit.normal.z <= 0.0:
        return None
    # A sweep stops up to one step (one radius) short of the contact: sweep
    # the last stretch again with ever smaller probes, each starting with its
    # bottom where the previous probe's bottom stopped.
    for finer in _REFINE_RADII:
        s = hit.position.frame.origin
        bottom = s.z - r
        fine_start = Position(hit.position.cell_id, hit.position.frame.with_origin(Vec3(s.x, s.y, bottom + finer)))
        fine_end = Position(hit.position.cell_id, hit.position.frame.with_origin(Vec3(s.x, s.y, bottom + finer - 2.0 * r)))
        fine = _ray_checked(world, fine_start, fine_end, finer, 0, cache)
        if not fine.hit or fine.normal is None or fine.normal.z <= 0.0:
            break
        hit, r = fine, finer
    n = hit.normal
    assert n is not None
    contact = hit.position.frame.origin - n * r
    # the contact's plane, extended to the point's own x, y
    z = contact.z - (n.x * (o.x - contact.x) + n.y * (o.y - contact.y)) / n.z
    return Ground(z, Plane(n, -n.dot(contact)), hit.cell, n.z >= FLOOR_Z, 0.0)
