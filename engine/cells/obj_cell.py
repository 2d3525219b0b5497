"""ObjCell: what every cell (outdoor LandCell, indoor EnvCell) has in common."""

from __future__ import annotations

from collections.abc import Callable
from typing import Final, TYPE_CHECKING

from ..geometry import Position, Sphere, Vec3
from ..terrain.water import ENTIRELY_WATER_DEPTH, SHORE_DEPTH, WaterType
from ..objects.obstacle import MoverObstacle
from ..transition.state import InsertType, TransitionState
from .broad_phase import PathReach, may_touch, mover_bounds, path_reach

if TYPE_CHECKING:
    from ..objects.obstacle import Obstacle
    from ..world.landblock import Landblock
    from ..transition.sphere_path import SpherePath
    from ..transition.transition import Transition
    from .cell_array import CellArray

__all__ = ["ObjCell", "EntryRestriction"]

#: path_reach's answer when nothing is culled
_NO_REACH: Final[PathReach] = (False, 0, 0.0, 0.0, 0.0, 0.0)

#: Signature of an entry-restriction hook: (cell, transition) -> TransitionState.
EntryRestriction = Callable[["ObjCell", "Transition"], int] | None


class ObjCell:
    """A cell of the world: an id, a placement, water, and the objects in it.

    `shadow_objects` lists the objects whose shadows reach into the cell, in
    the order they were added; they are tested newest first.
    """

    __slots__ = ("id", "pos", "water_type", "landblock", "shadow_objects", "restriction", "__weakref__")

    def __init__(self, cell_id: int, pos: Position) -> None:
        self.id = cell_id
        self.pos = pos
        self.water_type = WaterType.NOT_WATER
        self.landblock: Landblock | None = None
        self.shadow_objects: list[Obstacle] = []
        #: Optional hook: an entry restriction (housing barrier, PK zone) that
        #: may refuse a mover. None means anyone may enter.
        self.restriction: EntryRestriction = None

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.id:08X})"

    # -- collision entry points --------------------------------------------
    def find_collisions(self, transition: Transition) -> int:
        raise NotImplementedError

    def find_env_collisions(self, transition: Transition) -> int:
        raise NotImplementedError

    def check_entry_restrictions(self, transition: Transition) -> int:
        """ObjCell.check_entry_restrictions: ask the cell's restriction hook.

        The client refuses a mover at a housing barrier here. A cell with no
        hook lets everyone in; the cell the path began in never refuses.
        """
        hook = self.restriction
        if hook is None:
            return TransitionState.OK
        begin = transition.sphere_path.begin_cell
        if begin is not None and begin.id == self.id:
            return TransitionState.OK
        return hook(self, transition)

    def find_obj_collisions(self, transition: Transition) -> int:
        """Collide the path with the objects shadowed into this cell, newest first
        (ObjCell.FindObjCollisions).

        With the `skip_far_movers` setting, a live mover none of the path's
        spheres can reach is passed over: its own test would answer OK and
        change nothing (engine.cells.broad_phase)."""
        shadows = self.shadow_objects
        if not shadows:
            return TransitionState.OK
        path = transition.sphere_path
        if path.insert_type == InsertType.INITIAL_PLACEMENT:
            return TransitionState.OK
        mover = transition.object_info.obj
        cull = transition.settings.skip_far_movers
        # first a look at a mover's box in x and y against the footprint of the path's spheres: most movers
        # of a crowd fail it, and it costs four comparisons instead of may_touch's whole test
        look, block, lo_x, hi_x, lo_y, hi_y = path_reach(path) if cull else _NO_REACH
        for obj in reversed(shadows):  # (compiled: no index arithmetic; the tests change no shadow list)
            if obj is mover:
                continue
            if cull and isinstance(obj, MoverObstacle):
                other = obj.mover
                if other is mover:
                    continue  # the path's own shadow (its test answers OK at once)
                if look:
                    # (mover_bounds' check inlined: this runs for every mover of a crowded cell)
                    box = other.broad_phase_bounds
                    if box is None or box.position is not other.position:
                        box = mover_bounds(obj)
                    if (box.max_x < lo_x or box.min_x > hi_x or box.max_y < lo_y or box.min_y > hi_y) \
                            and box.block == block:
                        continue
                if not may_touch(obj, path):
                    continue
            state = obj.find_obj_collisions(transition)
            if state != TransitionState.OK:
                # the reference lets a placement pass through ethereal objects
                if path.insert_type == InsertType.PLACEMENT and obj.ethereal:
                    continue
                return state
            if cull:  # the test may have moved the check position or the spheres
                look, block, lo_x, hi_x, lo_y, hi_y = path_reach(path)
        return TransitionState.OK

    # -- membership ---------------------------------------------------------
    def point_in_cell(self, point: Vec3) -> bool:
        return False

    def find_transit_cells(
        self, position: Position, num_sphere: int, spheres: list[Sphere], cell_array: CellArray, path: SpherePath | None
    ) -> None:
        """Add the cells this cell's contents let the spheres reach (none here)."""
        return None

    def get_water_depth(self, point: Vec3) -> float:
        """ObjCell.get_water_depth: how far below the ground a mover floats."""
        wt = self.water_type
        if wt == WaterType.NOT_WATER:
            return 0.0
        if wt == WaterType.ENTIRELY_WATER:
            return ENTIRELY_WATER_DEPTH
        if self.landblock is not None:
            return self.landblock.calc_water_depth(self.id, point)
        return SHORE_DEPTH

    def get_block_water_type(self) -> int:
        if self.landblock is not None:
            return self.landblock.water_type
        return WaterType.NOT_WATER
