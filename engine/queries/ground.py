"""ground: the surface under a point, the walkable search straight down.

Outdoors it is the terrain triangle under the point's x, y (the one the
client's LandCell.find_terrain_poly gives a walkable search), with the
cell's water depth there (ObjCell.get_water_depth), unless something stands
on the land there above it: a building's shell (a roof, a porch, a step), a
static object (a bridge, a platform) or a mover that is not a creature. Then
it is that surface, where an object falling from the point comes to rest,
as the client's transition lands it (LandCell.find_collisions: terrain,
then the building, then the objects). Indoors (an EnvCell) it is the floor
polygon, a step or an object standing there. Both are found by a small
probe sphere swept straight down from the point as a missile's sweep is,
to the contact as a ray finds it (sweep.CONTACT_TOLERANCE), creatures and
players passed (a creature's head is not ground); the contact's plane is
extended to the point's x, y for the height. A probe is swept outdoors only
when the cell holds a building or an object's shadow, so plain land costs
one triangle lookup.
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
#: how far below an indoor point the floor is looked for, by default
MAX_GROUND_DROP: Final = 50.0
#: how far above the land an outdoor surface must be to count as standing on it (the probe's contact
#: with the land itself is found to sweep.CONTACT_TOLERANCE)
_ABOVE_LAND: Final = 1e-3


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
    if (home.cell_id & 0xFFFF) >= 0x100:
        return _probe_down(world, home, o.z - drop, cache)
    assert isinstance(cell, LandCell)  # an outdoor id names a LandCell
    tri = cell.find_terrain_poly(o, False)
    if tri is None:  # on the cell's edge against float rounding: the next cell owns it
        raise UnknownCellError(f"no terrain triangle under {position!r}")
    z = tri.height_at(o.x, o.y)
    if o.z > z and (cell.building is not None or cell.shadow_objects):
        # something may stand on the land here (a building, a static object, a non-creature mover):
        # the first surface the probe meets above the land is what a falling object would rest on
        on_top = _probe_down(world, home, z - GROUND_PROBE_RADIUS, cache)
        if on_top is not None and on_top.z > z + _ABOVE_LAND:
            return on_top
    plane = tri.plane
    return Ground(z, plane, home.cell_id, plane.normal.z >= FLOOR_Z, cell.get_water_depth(Vec3(o.x, o.y, z)))


def _probe_down(world: World, home: Position, bottom: float, cache: dict[int, ObjCell | None] | None) -> Ground | None:
    """What a probe sphere swept straight down from `home` to height `bottom` first rests on, creatures
    and players passed; None when nothing is met or what is met faces down."""
    o = home.frame.origin
    r = GROUND_PROBE_RADIUS
    # the probe starts with its bottom just above the point, so a point on the floor finds that floor
    start = Position(home.cell_id, home.frame.with_origin(Vec3(o.x, o.y, o.z + r + 0.01)))
    end = Position(home.cell_id, home.frame.with_origin(Vec3(o.x, o.y, bottom)))
    hit = _ray_checked(world, start, end, r, 0, cache, pass_creatures=True)
    n = hit.normal
    if not hit.hit or n is None or n.z <= 0.0:
        return None
    contact = hit.position.frame.origin - n * r
    # the contact's plane, extended to the point's own x, y
    z = contact.z - (n.x * (o.x - contact.x) + n.y * (o.y - contact.y)) / n.z
    return Ground(z, Plane(n, -n.dot(contact)), hit.cell, n.z >= FLOOR_Z, 0.0)
