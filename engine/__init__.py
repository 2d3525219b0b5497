"""acphys engine: the Asheron's Call client's collision-transition physics.

A plain library (no bus, no codec). Start with `load_scene` and `World`.

The errors, the geometry, the settings and the value types are imported with
the package; the World, the loaders and the trace replay (which bring in the
whole per-move machinery) on first use of their names, so a client that only
needs the value types does not load the engine's hot path.
"""

from typing import TYPE_CHECKING

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
    from .navigation.results import PathResult
    from .navigation.settings import NavSettings
    from .formats.dat_world import open_dat_world
    from .formats.load import load_scene
    from .formats.scene import world_from_scene_dict
    from .formats.trace import load_trace
    from .formats.trace_replay import run_case
    from .world.world import World

__getattr__ = lazy_getattr(
    __name__,
    {
        "World": ".world.world",
        "PathResult": ".navigation.results",
        "NavSettings": ".navigation.settings",
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
    "CylSphereSpec",
    "EngineError",
    "EngineSettings",
    "Frame",
    "LandblockNotLoadedError",
    "MoveResult",
    "MoverSpec",
    "NavSettings",
    "NonFiniteError",
    "ObjectState",
    "OutOfRangeError",
    "PathResult",
    "PlacementFailedError",
    "Plane",
    "Position",
    "Quat",
    "RETAIL",
    "SceneFormatError",
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
