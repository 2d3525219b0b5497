"""Spatial queries on a World: sight, rays, ground, placement (the library part; the service answers the same over the bus).

Each query runs the engine's own transition machinery on a throwaway sweep
object that no cell knows about, so a query never changes any mover.

The typed answers (results.py) are plain values; the query functions are
imported on first use of their names, so reading an answer does not load the
transition machinery.
"""

from typing import TYPE_CHECKING

from .._lazy import lazy_getattr
from .results import Blocker, Ground, PlacementResult, RayHit, SightResult

if TYPE_CHECKING:
    from .batch import grounds, grounds_array, rays, rays_array, sights, sights_array
    from .ground import ground
    from .placement import place
    from .sweep import CONTACT_TOLERANCE, SIGHT_RADIUS, ray, sight

__getattr__ = lazy_getattr(
    __name__,
    {
        "CONTACT_TOLERANCE": ".sweep",
        "SIGHT_RADIUS": ".sweep",
        "ray": ".sweep",
        "sight": ".sweep",
        "ground": ".ground",
        "place": ".placement",
        "grounds": ".batch",
        "grounds_array": ".batch",
        "rays": ".batch",
        "rays_array": ".batch",
        "sights": ".batch",
        "sights_array": ".batch",
    },
    globals(),
)

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
