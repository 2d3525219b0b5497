"""Obstacle shapes from acphys-scene/1 Setups and GfxObjs.

An object names a model: a Setup (`02xxxxxx`) or a bare GfxObj (`01xxxxxx`).
What the physics takes from it (ACE `Setup`, `PartArray`, `GfxObj`):
- the Setup's `spheres` and `cyl_spheres`;
- its parts (GfxObjs) placed by placement frame 0x65 (Resting), else 0
  (Default); with neither, a single part takes the object's own frame;
- each part's scale: the Setup's `default_scale` entry when it lists one per
  part, else 1, times the object's scale;
- a bare GfxObj is a one-part setup at the object's frame with no spheres
  (Setup.MakeSimpleSetup);
- the part GfxObj's physics BSP and its root's bounding sphere
  (`PhysicsSphere`); drawing-only parts have none.

`Obstacle.find_obj_collisions` then picks the shape: the parts' physics BSPs
if any part has one, else the cylspheres, else the spheres.
"""

from __future__ import annotations

from typing import Any
from collections.abc import Callable, Mapping

from ..bsp import build_bsp, build_polygons
from ..geometry import Frame, Position, Quat, Sphere, Vec3
from .cylsphere_collision import CylSphere
from .obstacle import Obstacle, ObstaclePart

__all__ = ["PhysicsGfx", "ObstacleShape", "ModelLibrary", "shape_from_setup", "shape_from_gfx_obj"]

#: GfxObj loader: dat id -> an object with `physics_bsp` (and optionally `physics_sphere`).
GfxLoader = Callable[[int], Any]

RESTING_PLACEMENT = 0x65
DEFAULT_PLACEMENT = 0


def _vec(v: Any) -> Vec3:
    return Vec3(float(v[0]), float(v[1]), float(v[2]))


def _frame(d: Mapping[str, Any]) -> Frame:
    q = d.get("orientation", (1.0, 0.0, 0.0, 0.0))
    return Frame(_vec(d.get("origin", (0.0, 0.0, 0.0))), Quat(float(q[0]), float(q[1]), float(q[2]), float(q[3])))


def _sphere(d: Mapping[str, Any]) -> Sphere:
    return Sphere(_vec(d["origin"] if "origin" in d else d["center"]), float(d["radius"]))


def _hex_id(text: Any) -> int:
    return text if isinstance(text, int) else int(text, 16)


class PhysicsGfx:
    """The physics half of a GfxObj: its physics BSP (or None) and that BSP's
    bounding sphere (ACE GfxObj.PhysicsBSP / PhysicsSphere)."""

    __slots__ = ("id", "physics_bsp", "physics_sphere", "physics_polygons")

    def __init__(self, gfx_id: int, physics_bsp: Any = None, physics_polygons: Any = None) -> None:
        self.id = gfx_id
        self.physics_bsp = physics_bsp
        self.physics_polygons = physics_polygons or {}
        self.physics_sphere = physics_bsp.get_sphere() if physics_bsp is not None else None

    def __repr__(self) -> str:
        return f"PhysicsGfx({self.id:08X}, bsp={self.physics_bsp is not None})"

    @classmethod
    def from_dict(cls, gfx_id: int, d: Mapping[str, Any]) -> PhysicsGfx:
        """From a scene GfxObj dict (`vertices`, `physics_polygons`, `physics_bsp`)."""
        if d.get("physics_bsp") is None:
            return cls(gfx_id)
        polygons = build_polygons(d.get("physics_polygons") or {}, d.get("vertices") or {})
        return cls(gfx_id, build_bsp(d["physics_bsp"], polygons), polygons)


class ObstacleShape:
    """What an object's model gives the physics: spheres, cylspheres, parts
    (gfx object, placement frame or None, default scale), and the Setup's
    step heights, height and radius."""

    __slots__ = ("spheres", "cyl_spheres", "parts", "step_up_height", "step_down_height", "height", "radius")

    def __init__(
        self,
        spheres: list[Sphere],
        cyl_spheres: list[CylSphere],
        parts: list[tuple[Any, Frame | None, Vec3]],
        *,
        step_up_height: float = 0.0,
        step_down_height: float = 0.0,
        height: float = 0.0,
        radius: float = 0.0,
    ) -> None:
        self.spheres = spheres
        self.cyl_spheres = cyl_spheres
        self.parts = parts
        self.step_up_height = step_up_height
        self.step_down_height = step_down_height
        self.height = height
        self.radius = radius

    @property
    def has_physics_bsp(self) -> bool:
        return any(getattr(g, "physics_bsp", None) is not None for g, _, _ in self.parts)

    def obstacle_parts(self, scale: float = 1.0) -> list[ObstaclePart]:
        """The parts as an Obstacle holds them (part scale = default scale x `scale`)."""
        return [ObstaclePart(g, f, s * scale) for g, f, s in self.parts]

    def make_obstacle(self, obj_id: int, position: Position, *, scale: float = 1.0, **flags: Any) -> Obstacle:
        """An Obstacle of this shape at `position` (flags as Obstacle's keywords)."""
        return Obstacle(
            obj_id,
            position,
            spheres=self.spheres,
            cyl_spheres=self.cyl_spheres,
            parts=self.obstacle_parts(scale),
            scale=scale,
            **flags,
        )


def shape_from_gfx_obj(gfx: Any) -> ObstacleShape:
    """A bare GfxObj as a model: one part at the object's frame, no spheres
    (Setup.MakeSimpleSetup)."""
    return ObstacleShape([], [], [(gfx, None, Vec3(1.0, 1.0, 1.0))])


def shape_from_setup(setup: Mapping[str, Any], gfx_loader: GfxLoader) -> ObstacleShape | None:
    """A scene Setup dict as a model; None for a setup without parts (the
    reference drops such an object)."""
    part_ids = [_hex_id(p) for p in setup.get("parts") or ()]
    if not part_ids:
        return None
    placements = setup.get("placement_frames") or {}
    placement = placements.get(str(RESTING_PLACEMENT))
    if placement is None:
        placement = placements.get(str(DEFAULT_PLACEMENT))
    frames = [_frame(f) for f in (placement or {}).get("frames", ())]
    scales = setup.get("default_scale")
    if scales is None or len(scales) != len(part_ids):
        part_scales = [Vec3(1.0, 1.0, 1.0)] * len(part_ids)
    else:
        part_scales = [_vec(s) for s in scales]

    parts: list[tuple[Any, Frame | None, Vec3]] = []
    for i, gid in enumerate(part_ids):
        if i < len(frames):
            frame: Frame | None = frames[i]
        else:
            # no placement frame: a lone part sits at the object's frame (the
            # reference leaves further parts unplaced; they take it too here)
            frame = None
        parts.append((gfx_loader(gid), frame, part_scales[i]))

    return ObstacleShape(
        [_sphere(s) for s in setup.get("spheres") or ()],
        [CylSphere.from_dict(c) for c in setup.get("cyl_spheres") or ()],
        parts,
        step_up_height=float(setup.get("step_up_height", 0.0)),
        step_down_height=float(setup.get("step_down_height", 0.0)),
        height=float(setup.get("height", 0.0)),
        radius=float(setup.get("radius", 0.0)),
    )


class ModelLibrary:
    """The `gfx_objs` and `setups` of one scene, built into shapes on first use
    and shared (BSP trees are built once per GfxObj).

    `gfx_loader` replaces the built-in GfxObj builder (e.g. a world's shared
    portal cache); it gets a dat id and returns an object with
    `physics_bsp`.
    """

    def __init__(self, scene: Mapping[str, Any], gfx_loader: GfxLoader | None = None) -> None:
        self.scene = scene
        self._gfx_loader = gfx_loader
        self._gfx: dict[int, Any] = {}
        self._shapes: dict[int, ObstacleShape | None] = {}

    def gfx_obj(self, gfx_id: int) -> Any:
        g = self._gfx.get(gfx_id)
        if g is None:
            if self._gfx_loader is not None:
                g = self._gfx_loader(gfx_id)
            else:
                d = (self.scene.get("gfx_objs") or {}).get(f"{gfx_id:08X}")
                if d is None:
                    raise KeyError(f"GfxObj {gfx_id:08X} is not in the scene")
                g = PhysicsGfx.from_dict(gfx_id, d)
            self._gfx[gfx_id] = g
        return g

    def shape(self, model_id: int | str) -> ObstacleShape | None:
        """The shape of a Setup or GfxObj id; None for a setup without parts."""
        mid = _hex_id(model_id)
        if mid in self._shapes:
            return self._shapes[mid]
        if mid >> 24 == 0x01:
            shape: ObstacleShape | None = shape_from_gfx_obj(self.gfx_obj(mid))
        else:
            d = (self.scene.get("setups") or {}).get(f"{mid:08X}")
            if d is None:
                raise KeyError(f"Setup {mid:08X} is not in the scene")
            shape = shape_from_setup(d, self.gfx_obj)
        self._shapes[mid] = shape
        return shape

    def obstacle(self, model_id: int | str, position: Position, *, obj_id: int = 0, scale: float = 1.0, **flags: Any) -> Obstacle | None:
        """An Obstacle of model `model_id` at `position`: by default a static
        dat object (id 0, no weenie); None when the model has no parts."""
        shape = self.shape(model_id)
        if shape is None:
            return None
        return shape.make_obstacle(obj_id, position, scale=scale, **flags)
