"""acphys engine: the Asheron's Call client's collision-transition physics.

A plain library (no bus, no codec). Start with `load_scene` and `World`.

The errors, the geometry, the settings and the value types are imported with
the package; the World, the loaders and the trace replay (which bring in the
whole per-move machinery) on first use of their names, so a client that only
needs the value types does not load the engine's hot path.

The engine's public face is this package's `__all__` and the few modules in
PUBLIC_MODULES: the service, the clients and the benchmarks import nothing
else of the engine (tests/test_engine_face.py checks it; the tests themselves
may reach anywhere). The face, by kind:

- value types: the geometry (engine.geometry: vectors, quaternions, planes,
  positions, the client's single-precision rounding) and the World's specs
  and results, the queries' and paths' answers (here);
- numbers: engine.limits (what a caller may give), engine.constants (the
  client's own constants), engine.settings (EngineSettings and its presets);
- errors: engine.errors (also here);
- the World and what it hands out: World, Mover (a World's movers, for
  annotations and state), MoveUndo (the undo a checked move returns);
- the batch API: engine.world.batch (run_batch, BatchRows, the mover-state
  record), the result columns it writes (engine.world.rows) and the
  transient-state bits results and mover states carry (engine.world.transient);
- the formats' loaders: load_scene, world_from_scene_dict, open_dat_world
  with DatCollection and DatError (here), and the trace format
  (engine.formats.trace: reading cases and replaying their moves).

Everything else (the transition, the movers' and worlds' insides, the
navigation's walk, graph and search, the terrain, the dat parsers) is the
engine's own and may change without notice.
"""

from typing import TYPE_CHECKING, Final

from ._lazy import lazy_getattr
from .errors import (
    EngineError,
    LandblockNotLoadedError,
    NonFiniteError,
    OutOfRangeError,
    PlacementFailedError,
    SceneFormatError,
    UnknownCellError,
    UnknownMoverError,
)
from .geometry import Frame, Plane, Position, Quat, Sphere, Vec3
from .settings import ACE_COMPAT, RETAIL, EngineSettings
from .world.types import CylSphereSpec, MoveResult, MoverSpec, ObjectState, SphereSpec

if TYPE_CHECKING:
    from .formats.dat import DatCollection, DatError
    from .navigation.results import PathResult
    from .navigation.settings import DEFAULT_NAV, REASONS, NavSettings
    from .queries.results import Blocker, Ground, PlacementResult, RayHit, SightResult
    from .formats.dat_world import open_dat_world
    from .formats.load import load_scene
    from .formats.scene import world_from_scene_dict
    from .formats.trace import load_trace
    from .formats.trace_replay import run_case
    from .world.mover import Mover
    from .world.rollback import MoveUndo
    from .world.world import World

#: the engine modules the service, the clients and the benchmarks may import,
#: besides this package (see the docstring; tests/test_engine_face.py)
PUBLIC_MODULES: Final = (
    "engine",
    "engine.geometry",
    "engine.limits",
    "engine.constants",
    "engine.settings",
    "engine.errors",
    "engine.world.batch",
    "engine.world.rows",
    "engine.world.transient",
    "engine.formats.trace",
)

__getattr__ = lazy_getattr(
    __name__,
    {
        "World": ".world.world",
        "Mover": ".world.mover",
        "MoveUndo": ".world.rollback",
        "PathResult": ".navigation.results",
        "NavSettings": ".navigation.settings",
        "DEFAULT_NAV": ".navigation.settings",
        "REASONS": ".navigation.settings",
        "Blocker": ".queries.results",
        "Ground": ".queries.results",
        "PlacementResult": ".queries.results",
        "RayHit": ".queries.results",
        "SightResult": ".queries.results",
        "DatCollection": ".formats.dat",
        "DatError": ".formats.dat",
        "load_scene": ".formats.load",
        "open_dat_world": ".formats.dat_world",
        "world_from_scene_dict": ".formats.scene",
        "load_trace": ".formats.trace",
        "run_case": ".formats.trace_replay",
    },
    globals(),
)

__all__ = [
    "ACE_COMPAT",
    "Blocker",
    "CylSphereSpec",
    "DEFAULT_NAV",
    "DatCollection",
    "DatError",
    "EngineError",
    "EngineSettings",
    "Frame",
    "Ground",
    "LandblockNotLoadedError",
    "MoveResult",
    "MoveUndo",
    "Mover",
    "MoverSpec",
    "NavSettings",
    "NonFiniteError",
    "ObjectState",
    "OutOfRangeError",
    "PathResult",
    "PlacementFailedError",
    "PlacementResult",
    "Plane",
    "Position",
    "Quat",
    "REASONS",
    "RETAIL",
    "RayHit",
    "SceneFormatError",
    "SightResult",
    "Sphere",
    "SphereSpec",
    "UnknownCellError",
    "UnknownMoverError",
    "Vec3",
    "World",
    "load_scene",
    "load_trace",
    "open_dat_world",
    "run_case",
    "world_from_scene_dict",
]
