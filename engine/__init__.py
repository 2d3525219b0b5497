"""acphys engine: the Asheron's Call client's collision-transition physics.

A plain library (no bus, no codec). Start with `load_scene` and `World`.
"""

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
from .formats.scene import load_scene, world_from_scene_dict
from .formats.trace import load_trace, run_case
from .geometry import Frame, Plane, Position, Quat, Sphere, Vec3
from .transition.settings import ACE_COMPAT, RETAIL, EngineSettings
from .world.types import CylSphereSpec, MoveResult, MoverSpec, ObjectState, SphereSpec
from .world.world import World

__all__ = [
    "ACE_COMPAT",
    "CylSphereSpec",
    "EngineError",
    "EngineSettings",
    "Frame",
    "LandblockNotLoadedError",
    "MoveResult",
    "MoverSpec",
    "NonFiniteError",
    "ObjectState",
    "OutOfRangeError",
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
    "run_case",
    "world_from_scene_dict",
]
