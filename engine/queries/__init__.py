"""Spatial queries on a World: sight, rays, ground, placement (issue 14, the library part).

Each query runs the engine's own transition machinery on a throwaway sweep
object that no cell knows about, so a query never changes any mover.
"""

from .results import Blocker, Ground, RayHit, SightResult
from .sweep import CONTACT_TOLERANCE, SIGHT_RADIUS, ray, sight
from .ground import ground
from .placement import PlacementResult, place
from .batch import grounds, grounds_array, rays, rays_array, sights, sights_array

__all__ = [
    "Blocker",
    "Ground",
    "RayHit",
    "SightResult",
    "SIGHT_RADIUS",
    "CONTACT_TOLERANCE",
    "ray",
    "sight",
    "ground",
    "place",
    "PlacementResult",
    "rays",
    "rays_array",
    "sights",
    "grounds",
    "grounds_array",
    "sights_array",
]
