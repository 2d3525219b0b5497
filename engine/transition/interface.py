"""What the collision layer (cells, BSP trees, objects) needs from a transition.

The cells and the BSP answer a transition's questions and call back into it:
they read its sphere path, collision info and object info, and ask it to
step up, to slide a sphere, or to settle on walkable ground. `CollisionTransition`
spells that interface out; `CellLookup` is what a cell search needs from the
world (the client's LScape).

Why the collision layer's annotations name the concrete `Transition` (imported
under `TYPE_CHECKING`, so there is no import at run time and no circle)
rather than these Protocols: in the mypyc-compiled engine an attribute read
or a method call through a Protocol (or `Any`) is a generic Python lookup,
while through a native class it is a direct struct read or C call. Measured
on a toy loop compiled with mypyc (one attribute read and one method call per
iteration): about 4x slower through a Protocol. The per-move path makes such
calls millions of times, so the Protocols document the interface, and mypy
checks here that `Transition` satisfies them (the pure-Python side, tests'
fakes and any other transition conform to the Protocol).

This module is a leaf of the transition package: it imports nothing of the
engine at run time.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol

if TYPE_CHECKING:
    from ..cells.obj_cell import ObjCell
    from ..geometry import Plane, Sphere, Vec3
    from .collision_info import CollisionInfo
    from .object_info import ObjectInfo
    from ..settings import EngineSettings
    from .sphere_path import SpherePath
    from .transition import Transition

__all__ = ["CellLookup", "CollisionTransition"]


class CellLookup(Protocol):
    """Where cells are found by id (LScape.get_landcell): the Landscape, or
    during loading the one landblock being built."""

    def get_landcell(self, cell_id: int) -> ObjCell | None: ...


class CollisionTransition(Protocol):
    """The transition as cells, BSP trees and objects see it (CTransition)."""

    sphere_path: SpherePath
    collision_info: CollisionInfo
    object_info: ObjectInfo
    settings: EngineSettings
    #: settings.single_precision, read once by the transition: the precision the
    #: collision routines compute and round at
    single_precision: bool

    def step_up(self, collision_normal: Vec3) -> bool:
        """Climb onto what the foot sphere ran into (Transition.StepUp)."""
        ...

    def slide_sphere(self, collision_normal: Vec3, curr_center: Vec3) -> int:
        """Slide the foot sphere along a global normal (SlideSphere)."""
        ...

    def validate_walkable(self, check_sphere: Sphere, plane: Plane, is_water: bool, water_depth: float, cell_id: int) -> int:
        """Settle on (or stop at) walkable terrain (Transition.ValidateWalkable)."""
        ...


if TYPE_CHECKING:

    def _transition_is_a_collision_transition(t: Transition) -> CollisionTransition:
        return t  # mypy fails here if Transition stops providing the interface
