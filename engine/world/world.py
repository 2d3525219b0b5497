"""World: loaded landblocks and the movers in them; answers moves.

    world = load_scene("rolling.json")
    mid = world.add_mover(MoverSpec(spheres=[SphereSpec((0, 0, 0.48), 0.48)]),
                          Position.at(0xA9B40001, Vec3(10, 10, 52)))
    result = world.move(mid, Position.at(0xA9B40001, Vec3(11, 10, 52)))
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

from .. import limits
from ..constants import MAX_VELOCITY
from ..errors import LandblockNotLoadedError, NonFiniteError, PlacementFailedError, UnknownMoverError
from ..geometry import Plane, Position, Vec3
from ..geometry.landdefs import adjust_to_outside
from ..settings import RETAIL, EngineSettings
from ..transition.state import OI
from .landblock import Landblock
from ..cells.landscape import Landscape
from ..cells.obj_cell import ObjCell
from ..queries import batch, sweep
from ..queries.ground import MAX_GROUND_DROP
from ..queries.ground import ground as ground_query
from ..queries.placement import place as place_query
from ..queries.results import Ground, PlacementResult, RayHit, SightResult
from ..navigation import path as navigation_path
from ..navigation.follow import follow as navigation_follow
from ..navigation.cache import NavCache
from ..navigation.graph import GraphStats
from ..navigation.results import PathResult
from ..navigation.walker import Walker
from . import shadows
from .mover import Mover
from .moves import move_checked, step_checked
from .placement import PLACEMENT_MODES, mover_from_spec, place_mover
from .resolve import move_result
from .transient import TS
from .types import MoveResult, MoverSpec, ObjectState

if TYPE_CHECKING:
    from ..formats.dat_world import DatLandblockSource

__all__ = ["World"]

#: A loader the World calls for a landblock it does not hold: id -> Landblock or None.
LandblockLoader = Callable[[int], "Landblock | None"]


class World:
    """Holds landblocks (loaded up front or on demand) and movers."""

    def __init__(self, settings: EngineSettings = RETAIL, loader: LandblockLoader | None = None) -> None:
        #: the loaded landblocks and settings, where transitions look cells up
        self.landscape = Landscape({}, settings, self.load_landblock if loader is not None else None)
        self.movers: dict[int, Mover] = {}
        self._next_mover_id = 1
        self._loader = loader
        self.stats = {"landblock_loads": 0, "landblock_unloads": 0}
        #: the DatLandblockSource of a World opened on dat files, else None
        self.dat_source: DatLandblockSource | None = None
        self._navigation: NavCache | None = None

    @property
    def settings(self) -> EngineSettings:
        return self.landscape.settings

    @settings.setter
    def settings(self, settings: EngineSettings) -> None:
        self.landscape.settings = settings

    @property
    def landblocks(self) -> dict[int, Landblock]:
        """Loaded landblocks by id."""
        return self.landscape.landblocks

    @landblocks.setter
    def landblocks(self, landblocks: dict[int, Landblock]) -> None:
        self.landscape.set_landblocks(landblocks)

    # -- landblocks -------------------------------------------------------------
    def add_landblock(self, landblock: Landblock) -> None:
        self.landblocks[landblock.id] = landblock
        self.stats["landblock_loads"] += 1

    def load_landblock(self, landblock_id: int) -> Landblock:
        """Make sure a landblock is loaded (from the World's source) and return it."""
        lb = self.landblocks.get(landblock_id)
        if lb is not None:
            return lb
        if self._loader is None:
            raise LandblockNotLoadedError(f"landblock {landblock_id:04X} is not loaded and this world has no source to load it from")
        lb = self._loader(landblock_id)
        if lb is None:
            raise LandblockNotLoadedError(f"landblock {landblock_id:04X} is not in this world's source")
        self.add_landblock(lb)
        return lb

    def unload_landblock(self, landblock_id: int) -> None:
        if self.landblocks.pop(landblock_id, None) is None:
            raise LandblockNotLoadedError(f"landblock {landblock_id:04X} is not loaded")
        self.stats["landblock_unloads"] += 1
        if self._navigation is not None:
            self._navigation.refresh()  # its graphs' tiles there (and beside it) go now, not at their next use

    def loaded_landblocks(self) -> list[int]:
        return sorted(self.landblocks)

    def get_landcell(self, cell_id: int) -> ObjCell | None:
        """The cell with this id if its landblock is loaded, else None (LScape.get_landcell)."""
        return self.landscape.get_landcell(cell_id)

    # -- movers -------------------------------------------------------------------
    def add_mover(
        self,
        spec: MoverSpec,
        position: Position,
        contact_plane: Plane | None = None,
        contact_plane_cell: int | None = None,
        *,
        sliding_normal: Vec3 | None = None,
        water_contact: bool = False,
        placement: str | None = None,
        slide: bool = True,
    ) -> int:
        """Register a mover at `position` with its starting contact state.

        With `placement` ("enter_world" or "teleport") the new mover is then
        placed as the client places an object entering the world
        (engine.world.placement.place_mover, `slide` letting it search for a
        free spot nearby): it stands where the placement puts it, with the
        contact state the placement leaves; a placement that finds no place
        raises PlacementFailedError and registers nothing.

        Every number is checked against engine.limits first: a refused
        mover changes nothing."""
        if placement is not None:
            if placement not in PLACEMENT_MODES:
                raise ValueError(f"placement must be one of {PLACEMENT_MODES}, got {placement!r}")
        limits.check_mover_spec(spec, "spec")
        limits.check_start(position, "position", limits.start_slack(spec))
        if contact_plane is not None:
            limits.check_plane(contact_plane, "contact_plane")
        if sliding_normal is not None:
            limits.check_sliding_normal(sliding_normal, "sliding_normal")
        self._check_position(position)
        mover = mover_from_spec(self._next_mover_id, spec)
        mover.position = position
        mover.cell = self._cell_for(position)
        flags = ObjectState.from_names(spec.state)
        if contact_plane is not None:
            if not (contact_plane.normal.is_finite() and math.isfinite(contact_plane.d)):
                raise NonFiniteError("contact plane has non-finite numbers")
            mover.contact_plane = contact_plane
            mover.contact_plane_cell_id = contact_plane_cell if contact_plane_cell is not None else position.cell_id
            if flags & OI.CONTACT:
                mover.transient |= TS.CONTACT
                if flags & OI.ON_WALKABLE:
                    mover.transient |= TS.ON_WALKABLE
            if water_contact:
                mover.transient |= TS.WATER_CONTACT
        if sliding_normal is not None:
            mover.sliding_normal = sliding_normal
            mover.transient |= TS.SLIDING
        mover.calc_acceleration(self.settings.sled_gravity)
        self._enter_cells(mover)
        self.movers[mover.id] = mover
        self._next_mover_id += 1
        if placement is not None:
            self._place_new(mover.id, position, placement, slide)
        return mover.id

    def _place_new(self, mover_id: int, position: Position, mode: str, slide: bool) -> None:
        """Place a just-registered mover; unregister it again if there is no place."""
        try:
            placed = place_mover(self, mover_id, position, mode, slide)
        except BaseException:
            self._unregister_newest(mover_id)
            raise
        if not placed.ok:
            self._unregister_newest(mover_id)
            raise PlacementFailedError(f"no place for the mover at {position!r}: {placed.placement_result}")

    def _unregister_newest(self, mover_id: int) -> None:
        self.remove_mover(mover_id)
        self._next_mover_id = mover_id  # as if it had never come

    def mover(self, mover_id: int) -> Mover:
        try:
            return self.movers[mover_id]
        except KeyError:
            raise UnknownMoverError(f"no mover with id {mover_id}") from None

    def remove_mover(self, mover_id: int) -> None:
        mover = self.mover(mover_id)
        shadows.remove_shadows(mover)
        del self.movers[mover_id]

    def update_mover(self, mover_id: int, spec: MoverSpec) -> None:
        """Change a mover's shape and flags, keeping its position, contact state and move count (seq, last)."""
        old = self.mover(mover_id)
        new = mover_from_spec(mover_id, spec)  # checks the spec: a refused one changes nothing
        for name in ("position", "cell", "transient", "contact_plane", "contact_plane_cell_id", "sliding_normal", "velocity", "acceleration", "held_time", "held_motion",
                     "seq", "last"):
            setattr(new, name, getattr(old, name))
        shadows.remove_shadows(old)
        self.movers[mover_id] = new
        self._enter_cells(new)

    def set_velocity(self, mover_id: int, velocity: Vec3) -> Vec3:
        """Give a mover a velocity of its own, as the client's CPhysicsObj::set_velocity does
        (a jump, a launch, a push): a speed above MaxVelocity (50 m/s) is scaled down to it.
        Later physics steps (`step`) carry it on under gravity and friction. The velocity
        set, after the clamp."""
        mover = self.mover(mover_id)
        limits.check_velocity(velocity, "velocity")
        length = velocity.length()
        if length > MAX_VELOCITY:
            velocity = velocity * (MAX_VELOCITY / length)
        mover.velocity = velocity
        return velocity

    def mover_state(self, mover_id: int) -> MoveResult:
        """The mover as it stands, as a NoTransition result carrying its move count (`seq`) as it is:
        asking is no move, so it counts nothing (Mover.seq and Mover.last stay)."""
        return move_result(self.mover(mover_id), True, "NoTransition", None)

    # -- moves ----------------------------------------------------------------------
    def move(self, mover_id: int, target: Position, velocity: Vec3 | None = None) -> MoveResult:
        """Move a mover toward `target` (one PhysicsObj.transition + SetPositionInternal).

        `velocity` is the mover's velocity while the move is resolved (what the
        contact checks and collision responses see); None keeps its own.
        """
        # the table read here, not through self.mover (an interpreted call less per move); a missing id
        # still raises there
        mover = self.movers.get(mover_id)
        return move_checked(self.landscape, mover if mover is not None else self.mover(mover_id), target, velocity)

    def step(self, mover_id: int, motion: Vec3, dt: float) -> MoveResult:
        """Advance a mover by `dt` seconds with its own motion `motion` (metres
        over `dt`, object frame) under velocity, gravity and friction.

        With the settings' `quantum_ladder` (RETAIL) `dt` is a frame's real
        elapsed time, spent as the client's PhysicsObj.update_object spends
        it (engine.world.quantum): time short of the minimum quantum (1/30 s)
        is held with its motion until later steps bring enough, long time
        runs as several physics steps of at most `max_quantum` (the motion
        shared among them in proportion to their time), time beyond the huge
        quantum (2 s, held time included) is dropped with its motion. A step
        that runs nothing answers the mover's state as it stands, with
        transition_state "NoTransition"; one that runs several answers the
        last one's result, with the objects hit by any of them.

        Without it (ACE_COMPAT) `dt` is one integration step as given
        (UpdateObjectInternal), as the reference traces record them."""
        mover = self.movers.get(mover_id)  # (as in move)
        return step_checked(self.landscape, mover if mover is not None else self.mover(mover_id), motion, dt)

    def _enter_cells(self, mover: Mover) -> None:
        """Cast the mover's shadow into the cells its spheres touch, so other
        movers collide with it (the client adds a new object to its cell and
        its CellArray)."""
        shadows.enter_world(self.landscape, mover)

    # -- checks -----------------------------------------------------------------------
    def _check_position(self, position: Position) -> None:
        self.landscape.check_position(position)

    def _ensure_loaded(self, cell_id: int) -> None:
        self.landscape.ensure_loaded(cell_id)

    def _cell_for(self, position: Position) -> ObjCell | None:
        cell = self.get_landcell(position.cell_id)
        if cell is None and (position.cell_id & 0xFFFF) < 0x100:
            cell_id, _ = adjust_to_outside(position.cell_id, position.frame.origin)
            cell = self.get_landcell(cell_id)
        return cell

    # -- spatial queries (engine.queries; none of them changes any mover) ----------------
    def sight(self, a: Position, b: Position, radius: float | None = None, *, target_id: int = 0, viewer_id: int = 0) -> SightResult:
        """Is the line from eye `a` to eye `b` clear? A SightResult (engine.queries.sweep.sight);
        `target_id` the mover looked at, `viewer_id` the mover looking."""
        return sweep.sight(self, a, b, sweep.SIGHT_RADIUS if radius is None else radius, target_id=target_id, viewer_id=viewer_id)

    def ray(self, start: Position, end: Position, radius: float, *, target_id: int = 0) -> RayHit:
        """The first contact of a sphere swept from `start` to `end`: a RayHit (engine.queries.sweep.ray)."""
        return sweep.ray(self, start, end, radius, target_id=target_id)

    def ground(self, position: Position, max_drop: float | None = None) -> Ground | None:
        """The surface under `position`: a Ground, or None (engine.queries.ground)."""
        return ground_query(self, position, MAX_GROUND_DROP if max_drop is None else max_drop)

    def place(self, spec: MoverSpec, position: Position, mode: str = "enter_world", slide: bool = True) -> PlacementResult:
        """Where an object of shape `spec` would be placed at `position`, without
        placing anything: a PlacementResult (engine.queries.placement)."""
        return place_query(self, spec, position, mode, slide)

    def sights(
        self,
        eyes: Sequence[Position],
        targets: Sequence[Position],
        radius: float | None = None,
        *,
        target_ids: Sequence[int] | None = None,
        viewer_ids: Sequence[int] | None = None,
    ) -> list[SightResult]:
        """`sight` for each pair: a list of SightResult (engine.queries.batch)."""
        r = sweep.SIGHT_RADIUS if radius is None else radius
        return batch.sights(self, eyes, targets, r, target_ids=target_ids, viewer_ids=viewer_ids)

    def rays(self, starts: Sequence[Position], ends: Sequence[Position], radius: float) -> list[RayHit]:
        """`ray` for each pair: a list of RayHit (engine.queries.batch)."""
        return batch.rays(self, starts, ends, radius)

    def grounds(self, positions: Sequence[Position], max_drop: float | None = None) -> list[Ground | None]:
        """`ground` for each position: a list of Ground or None (engine.queries.batch)."""
        return batch.grounds(self, positions, MAX_GROUND_DROP if max_drop is None else max_drop)

    # -- navigation (engine.navigation; none of it changes any mover) -----------------------
    @property
    def navigation(self) -> NavCache:
        """The navigation graphs and their settings (`world.navigation.settings = NavSettings(...)`)."""
        if self._navigation is None:
            self._navigation = NavCache(self)
        return self._navigation

    def path(self, walker: Walker, start: Position | None, goal: Position, *, max_distance: float | None = None,
             budget: int | None = None, avoid_movers: bool = False, work: int | None = None) -> PathResult:
        """A path `walker` (a MoverSpec, or a registered mover's id with `start` None: it starts where it
        stands) can walk from `start` to `goal`: a PathResult.

        The guarantee: walk the waypoints in turn as engine.navigation.walk says (World.move, moves of
        at most NavSettings.stride metres, default 3, straight toward the next waypoint, until within
        NavSettings.arrival_tolerance, default 0.25 m) and the walker reaches every waypoint, standing on
        walkable ground in the waypoint's cell, the goal last. A MoverSpec walker starts as
        `add_mover(spec, waypoints[0], placement="enter_world")` places it. Other movers are not
        obstacles unless `avoid_movers` (then the movers standing now are), and the guarantee holds while
        the world stays as it was asked in. `max_distance` bounds the path's length, metres; `budget`
        the graph nodes the search may expand (NavSettings.budget by default). `work` bounds the graph
        building this query may start (placements and walks; None: no bound): a service answering many
        clients on one thread gives each query a share and answers "building" past it, the work done
        kept for the next. A path not found says why in `reason` (engine.navigation.results.PathResult)."""
        return navigation_path.find_path(self, walker, start, goal, max_distance=max_distance, budget=budget,
                                         avoid_movers=avoid_movers, work=work)

    def paths(self, walker: Walker, pairs: Sequence[tuple[Position | None, Position]], *, max_distance: float | None = None,
              budget: int | None = None, avoid_movers: bool = False, work: int | None = None) -> list[PathResult]:
        """`path` for each (start, goal) pair: a list of PathResult."""
        return navigation_path.find_paths(self, walker, pairs, max_distance=max_distance, budget=budget,
                                          avoid_movers=avoid_movers, work=work)

    def reachable(self, walker: Walker, a: Position | None, b: Position, *, max_distance: float | None = None,
                  budget: int | None = None, avoid_movers: bool = False) -> bool:
        """Whether `path(walker, a, b)` finds a path."""
        return self.path(walker, a, b, max_distance=max_distance, budget=budget, avoid_movers=avoid_movers).found

    def random_point(self, walker: Walker, near: Position | None, radius: float, *, seed: int | None = None,
                     budget: int | None = None, avoid_movers: bool = False, work: int | None = None) -> PathResult:
        """A random point within `radius` metres (horizontally) of `near` that the walker can reach, as a
        PathResult whose last waypoint is the point (the wandering query); `seed` makes it repeatable."""
        return navigation_path.random_point(self, walker, near, radius, seed=seed, budget=budget, avoid_movers=avoid_movers,
                                            work=work)

    def follow(self, mover_id: int, waypoints: Sequence[Position]) -> int:
        """Walk a registered mover over a path's waypoints (it stands at the first) by World.move, as the
        path's guarantee says (engine.navigation.follow); how many it reached, len(waypoints) - 1 when all."""
        return navigation_follow(self, mover_id, waypoints)

    def build_navigation(self, walker: Walker, landblock_ids: Sequence[int] | None = None) -> GraphStats:
        """Build the walker class's navigation graph of these landblocks (all loaded ones by default) now,
        every node and every edge, instead of as paths reach them; what the graph then holds."""
        probe = navigation_path.probe_of(self, walker)
        graph = self.navigation.graph_for(probe)
        for lb_id in (self.loaded_landblocks() if landblock_ids is None else landblock_ids):
            graph.build_landblock(lb_id)
        return graph.stats()

    # -- terrain queries -----------------------------------------------------------------
    def terrain_height(self, cell_id: int, x: float, y: float) -> float:
        """Terrain z under landblock-local (x, y) of the landblock of `cell_id`."""
        lb = self.landblocks.get((cell_id >> 16) & 0xFFFF)
        if lb is None:
            raise LandblockNotLoadedError(f"landblock {(cell_id >> 16) & 0xFFFF:04X} is not loaded")
        return lb.terrain.height_at(x, y)
