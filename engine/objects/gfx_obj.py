"""GfxObj (physics part) and PhysicsPart: BSP geometry placed in the world."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any
from collections.abc import Mapping

from ..bsp import build_bsp, build_polygons
from ..bsp.bbox import BBox
from ..bsp.build import build_vertices
from ..bsp.tree import BSPTree
from ..constants import EPSILON
from ..geometry import Position, Sphere
from ..transition.state import InsertType, TransitionState

if TYPE_CHECKING:
    from ..transition.transition import Transition

__all__ = ["GfxObj", "PhysicsPart"]


class GfxObj:
    """The physics half of a GfxObj: its physics BSP, bounding sphere and box."""

    __slots__ = ("id", "physics_bsp", "physics_sphere", "bound_box")

    def __init__(self, gfx_id: int, physics_bsp: BSPTree | None, bound_box: BBox) -> None:
        self.id = gfx_id
        self.physics_bsp = physics_bsp
        self.physics_sphere = physics_bsp.get_sphere() if physics_bsp is not None else None
        self.bound_box = bound_box

    @classmethod
    def from_dict(cls, gfx_id: int, d: Mapping[str, Any]) -> GfxObj:
        vertices = d.get("vertices", {})
        bsp = None
        if d.get("physics_bsp"):
            bsp = build_bsp(d["physics_bsp"], build_polygons(d.get("physics_polygons", {}), vertices))
        points = list(build_vertices(vertices).values())
        box = BBox.from_points(points) if points else BBox()
        return cls(gfx_id, bsp, box)

    def find_obj_collisions(self, transition: Transition, scale_z: float) -> int:
        """Collide when a path sphere reaches the part's bounding sphere
        (GfxObj.FindObjCollisions; the spheres are already in part space)."""
        bsp = self.physics_bsp
        sphere = self.physics_sphere
        if bsp is None or sphere is None:
            return TransitionState.OK
        path = transition.sphere_path
        sc = sphere.center
        for local in path.local_space_sphere:
            lc = local.center
            ox = sc.x - lc.x
            oy = sc.y - lc.y
            oz = sc.z - lc.z
            radsum = sphere.radius + local.radius
            if ox * ox + oy * oy + oz * oz - radsum * radsum < EPSILON:
                if path.insert_type == InsertType.INITIAL_PLACEMENT:
                    return bsp.placement_insert(transition)
                return bsp.find_collisions(transition, scale_z)
        return TransitionState.OK


class PhysicsPart:
    """One part of an object: a GfxObj at a position, with its scale."""

    __slots__ = ("gfx_obj", "pos", "scale_z")

    def __init__(self, gfx_obj: GfxObj, pos: Position, scale_z: float = 1.0) -> None:
        self.gfx_obj = gfx_obj
        self.pos = pos
        self.scale_z = scale_z

    def find_obj_collisions(self, transition: Transition) -> int:
        """PhysicsPart.FindObjCollisions: move the path into part space, collide."""
        if self.gfx_obj.physics_bsp is None:
            return TransitionState.OK
        transition.sphere_path.cache_local_space_sphere(self.pos, self.scale_z)
        return self.gfx_obj.find_obj_collisions(transition, self.scale_z)

    def bounding_sphere(self) -> Sphere | None:
        return self.gfx_obj.physics_sphere
