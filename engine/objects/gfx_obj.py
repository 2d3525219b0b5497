"""GfxObj and PhysicsPart: a part's physics geometry and that geometry placed
in the world (the client's CGfxObj and CPhysicsPart).

Every object made of parts goes through these two: a building's shell
(CBuildingObj) and a static or live object with physics BSP parts (an
`Obstacle`, the obstacle side of CPhysicsObj).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Final
from collections.abc import Mapping

from ..bsp import build_bsp, build_polygons
from ..bsp.tree import BSPTree
from ..constants import EPSILON
from ..geometry import Frame, Position, Vec3
from ..transition.state import InsertType, TransitionState

if TYPE_CHECKING:
    from ..transition.transition import Transition

__all__ = ["GfxObj", "PhysicsPart"]

_OK: Final = TransitionState.OK


class GfxObj:
    """The physics half of the client's CGfxObj: its physics BSP (None for a
    drawing-only part) and the BSP root's bounding sphere (`physics_sphere`)."""

    __slots__ = ("id", "physics_bsp", "physics_sphere")

    def __init__(self, gfx_id: int, physics_bsp: BSPTree | None = None) -> None:
        self.id = gfx_id
        self.physics_bsp = physics_bsp
        self.physics_sphere = physics_bsp.get_sphere() if physics_bsp is not None else None

    def __repr__(self) -> str:
        return f"GfxObj({self.id:08X}, bsp={self.physics_bsp is not None})"

    @classmethod
    def from_dict(cls, gfx_id: int, d: Mapping[str, Any]) -> GfxObj:
        """From a scene GfxObj dict (`vertices`, `physics_polygons`, `physics_bsp`)."""
        if not d.get("physics_bsp"):
            return cls(gfx_id)
        polygons = build_polygons(d.get("physics_polygons") or {}, d.get("vertices") or {})
        return cls(gfx_id, build_bsp(d["physics_bsp"], polygons))

    def find_obj_collisions(self, transition: Transition, scale_z: float) -> int:
        """CGfxObj::FindObjCollisions: the BSP is consulted only when a path
        sphere (already cached in part space) reaches the bounding sphere; the
        first such sphere decides, placing or colliding by the insert type."""
        bsp = self.physics_bsp
        sphere = self.physics_sphere
        if bsp is None or sphere is None:
            return _OK
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
        return _OK


class PhysicsPart:
    """One part of an object (the client's CPhysicsPart): a GfxObj, its
    placement frame in the owner's frame (None: the owner's own frame, a lone
    part without placement frames), its scale (the Setup's default scale
    times the owner's) and its place in the world, `pos`, set by `place`."""

    __slots__ = ("gfx_obj", "placement", "gfx_scale", "pos")

    def __init__(self, gfx_obj: GfxObj, placement: Frame | None, gfx_scale: Vec3, owner: Position, owner_scale: float = 1.0) -> None:
        self.gfx_obj = gfx_obj
        self.placement = placement
        self.gfx_scale = gfx_scale
        self.pos = owner
        self.place(owner, owner_scale)

    def __repr__(self) -> str:
        return f"PhysicsPart({self.gfx_obj!r}, {self.placement!r}, {self.gfx_scale!r})"

    def place(self, owner: Position, owner_scale: float) -> None:
        """CPartArray::UpdateParts for this part: the owner's frame combined
        with the placement frame, whose offset is scaled by the owner's scale."""
        placement = self.placement
        if placement is None:
            self.pos = owner
        else:
            self.pos = Position(owner.cell_id, owner.frame.combine(placement, Vec3(owner_scale, owner_scale, owner_scale)))

    def find_obj_collisions(self, transition: Transition) -> int:
        """CPhysicsPart::FindObjCollisions: the path's spheres into part space
        (divided by the part's z scale), then the GfxObj's test."""
        gfx = self.gfx_obj
        if gfx.physics_bsp is None:
            return _OK
        scale_z = self.gfx_scale.z
        transition.sphere_path.cache_local_space_sphere(self.pos, scale_z)
        return gfx.find_obj_collisions(transition, scale_z)

