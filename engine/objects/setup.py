"""Setups and GfxObjs from acphys-scene/1 dicts: the one model loader.

An object or a building names a model: a Setup (`02xxxxxx`) or a bare GfxObj
(`01xxxxxx`). What the physics takes from it (the client's CSetup,
CPartArray, CGfxObj):
- the Setup's `spheres` and `cyl_spheres`;
- its parts (GfxObjs) placed by placement frame 0x65 (Resting), else 0
  (Default); with neither, a part takes the object's own frame;
- each part's scale: the Setup's `default_scale` entry when it lists one per
  part, else 1, times the object's scale;
- a bare GfxObj is a one-part setup at the object's frame with no spheres
  (CSetup::makeSimpleSetup);
- a Setup without parts makes no object (CPartArray::InitParts fails);
- the part GfxObj's physics BSP and its root's bounding sphere; drawing-only
  parts have none.

Frames are read at single precision, as the dats hold them and the client
reads them (`frame_from_dict`, used for every frame of a scene).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Final
from collections.abc import Mapping

from ..errors import SceneFormatError
from ..geometry import Frame, Position, Quat, Sphere, Vec3
from ..geometry.precision import fl_vec
from ..geometry.single import to_single
from .cylsphere_collision import CylSphere
from .gfx_obj import GfxObj, PhysicsPart
from .obstacle import Obstacle

__all__ = ["Setup", "ModelLibrary", "frame_from_dict"]

RESTING_PLACEMENT: Final = 0x65
DEFAULT_PLACEMENT: Final = 0
_ONE: Final = Vec3(1.0, 1.0, 1.0)


def _vec(v: Any) -> Vec3:
    return Vec3(float(v[0]), float(v[1]), float(v[2]))


def frame_from_dict(d: Mapping[str, Any]) -> Frame:
    """A scene frame (`origin`, `orientation` w x y z), at the single
    precision the dats (and the client) hold it."""
    q = d.get("orientation", (1.0, 0.0, 0.0, 0.0))
    return Frame(
        fl_vec(_vec(d.get("origin", (0.0, 0.0, 0.0))), True),
        Quat(to_single(float(q[0])), to_single(float(q[1])), to_single(float(q[2])), to_single(float(q[3]))),
    )


def _sphere(d: Mapping[str, Any]) -> Sphere:
    return Sphere(_vec(d["origin"] if "origin" in d else d["center"]), float(d["radius"]))


def _hex_id(text: Any, what: str = "model id") -> int:
    if isinstance(text, int):
        return text
    try:
        return int(text, 16)
    except (TypeError, ValueError):
        raise SceneFormatError(f"{what}: expected a hex string, got {text!r}") from None


@dataclass(slots=True, eq=False)
class Setup:
    """What a model gives the physics (the physics half of the client's
    CSetup): spheres, cylspheres, its parts' GfxObjs with their placement
    frames (None: the object's frame) and default scales, and its step
    heights, height and radius."""

    spheres: list[Sphere]
    cyl_spheres: list[CylSphere]
    part_gfx: list[GfxObj]
    placement_frames: list[Frame | None]
    default_scales: list[Vec3]
    step_up_height: float = 0.0
    step_down_height: float = 0.0
    height: float = 0.0
    radius: float = 0.0

    @classmethod
    def simple(cls, gfx: GfxObj) -> Setup:
        """A bare GfxObj as a model: one part at the object's frame, no
        spheres (CSetup::makeSimpleSetup)."""
        return cls([], [], [gfx], [None], [_ONE])

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], gfx_obj: Any) -> Setup | None:
        """A scene Setup dict, its parts' GfxObjs got from `gfx_obj(id)`; None
        for a setup without parts (the client makes no object of it)."""
        part_ids = [_hex_id(p, "setup part") for p in d.get("parts") or ()]
        if not part_ids:
            return None
        placements = d.get("placement_frames") or {}
        placement = placements.get(str(RESTING_PLACEMENT)) or placements.get(str(DEFAULT_PLACEMENT))
        frames = [frame_from_dict(f) for f in (placement or {}).get("frames", ())]
        # a part past the placement frames sits at the object's frame
        placed: list[Frame | None] = [frames[i] if i < len(frames) else None for i in range(len(part_ids))]
        scales = d.get("default_scale")
        if scales is None or len(scales) != len(part_ids):
            default_scales = [_ONE] * len(part_ids)
        else:
            default_scales = [_vec(s) for s in scales]
        return cls(
            [_sphere(s) for s in d.get("spheres") or ()],
            [CylSphere.from_dict(c) for c in d.get("cyl_spheres") or ()],
            [gfx_obj(gid) for gid in part_ids],
            placed,
            default_scales,
            step_up_height=float(d.get("step_up_height", 0.0)),
            step_down_height=float(d.get("step_down_height", 0.0)),
            height=float(d.get("height", 0.0)),
            radius=float(d.get("radius", 0.0)),
        )

    @property
    def has_physics_bsp(self) -> bool:
        return any(g.physics_bsp is not None for g in self.part_gfx)

    def make_parts(self, position: Position, scale: float = 1.0) -> list[PhysicsPart]:
        """The parts placed for an object at `position` (CPartArray:
        part scale = default scale x `scale`)."""
        return [
            PhysicsPart(g, f, s * scale, position, scale)
            for g, f, s in zip(self.part_gfx, self.placement_frames, self.default_scales)
        ]

    def make_obstacle(self, obj_id: int, position: Position, *, scale: float = 1.0, **flags: Any) -> Obstacle:
        """An Obstacle of this model at `position` (flags as Obstacle's keywords)."""
        return Obstacle(
            obj_id,
            position,
            spheres=self.spheres,
            cyl_spheres=self.cyl_spheres,
            parts=self.make_parts(position, scale),
            scale=scale,
            **flags,
        )


class ModelLibrary:
    """The `gfx_objs` and `setups` of one scene, built on first use and
    shared (a GfxObj's BSP is built once), as the client's object caches
    share them."""

    def __init__(self, scene: Mapping[str, Any]) -> None:
        self.scene = scene
        self._gfx: dict[int, GfxObj] = {}
        self._setups: dict[int, Setup | None] = {}

    def gfx_obj(self, gfx_id: int) -> GfxObj:
        g = self._gfx.get(gfx_id)
        if g is None:
            d = (self.scene.get("gfx_objs") or {}).get(f"{gfx_id:08X}")
            if d is None:
                raise SceneFormatError(f"GfxObj {gfx_id:08X} is not in the scene")
            g = self._gfx[gfx_id] = GfxObj.from_dict(gfx_id, d)
        return g

    def setup(self, model_id: int | str) -> Setup | None:
        """The model of a Setup or GfxObj id; None for a setup without parts."""
        mid = _hex_id(model_id)
        if mid in self._setups:
            return self._setups[mid]
        if mid >> 24 == 0x01:
            setup: Setup | None = Setup.simple(self.gfx_obj(mid))
        else:
            d = (self.scene.get("setups") or {}).get(f"{mid:08X}")
            if d is None:
                raise SceneFormatError(f"Setup {mid:08X} is not in the scene")
            setup = Setup.from_dict(d, self.gfx_obj)
        self._setups[mid] = setup
        return setup

    def parts(self, model_id: int | str, position: Position, scale: float = 1.0) -> list[PhysicsPart]:
        """The placed parts of a model at `position` (none for a setup without parts)."""
        setup = self.setup(model_id)
        return [] if setup is None else setup.make_parts(position, scale)

    def obstacle(self, model_id: int | str, position: Position, *, obj_id: int = 0, scale: float = 1.0, **flags: Any) -> Obstacle | None:
        """An Obstacle of model `model_id` at `position`: by default a static
        dat object (id 0, no weenie); None when the model has no parts."""
        setup = self.setup(model_id)
        if setup is None:
            return None
        return setup.make_obstacle(obj_id, position, scale=scale, **flags)
