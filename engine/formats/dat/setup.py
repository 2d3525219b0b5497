"""Setup records (`0x02......` in the portal dat): a multi-part object's model.

Besides its parts and collision shapes a Setup holds placement frames, and a
placement frame may carry animation hooks. Hooks are skipped by their known
sizes; an unknown hook type raises DatError, since nothing after it could be
located.
"""

from __future__ import annotations

from typing import Any

from .binary import RecordReader
from .shapes import dat_id_hex, read_cyl_sphere, read_frame, read_sphere

__all__ = [
    "parse_setup",
    "SETUP_HAS_PARENT",
    "SETUP_HAS_DEFAULT_SCALE",
    "SETUP_ALLOW_FREE_HEADING",
    "SETUP_HAS_PHYSICS_BSP",
    "HOOK_PAYLOAD_SIZES",
]

SETUP_HAS_PARENT = 0x1
SETUP_HAS_DEFAULT_SCALE = 0x2
SETUP_ALLOW_FREE_HEADING = 0x4
SETUP_HAS_PHYSICS_BSP = 0x8

_HOOK_REPLACE_OBJECT = 5
# Bytes after a hook's (type, direction) header, by AnimationHookType.
HOOK_PAYLOAD_SIZES: dict[int, int] = {
    1: 4,  # Sound: wave id
    2: 4,  # SoundTable: sound type
    3: 28,  # Attack: AttackCone (part index, 2 x 2D points, radius, height)
    4: 0,  # AnimationDone
    6: 4,  # Ethereal
    7: 16,  # TransparentPart: part, start, end, time
    8: 12,  # Luminous: start, end, time
    9: 16,  # LuminousPart
    10: 12,  # Diffuse
    11: 16,  # DiffusePart
    12: 8,  # Scale: end, time
    13: 40,  # CreateParticle: emitter info id, part index, frame, emitter id
    14: 4,  # DestroyParticle
    15: 4,  # StopParticle
    16: 4,  # NoDraw
    17: 0,  # DefaultScript
    18: 4,  # DefaultScriptPart
    19: 8,  # CallPES: script id, pause
    20: 12,  # Transparent
    21: 16,  # SoundTweaked: wave id, priority, probability, volume
    22: 12,  # SetOmega: axis
    23: 8,  # TextureVelocity
    24: 12,  # TextureVelocityPart
    25: 4,  # SetLight
    26: 40,  # CreateBlockingParticle: laid out as CreateParticle
}

_MIN_LOCATION = 4 + 4 + 28
_MIN_PLACEMENT = 4 + 4
_MIN_LIGHT = 4 + 28 + 16


def _skip_hook(r: RecordReader) -> None:
    hook_type = r.u32("animation hook type")
    r.u32("animation hook direction")
    if hook_type == _HOOK_REPLACE_OBJECT:
        r.u16("replace-object part index")
        r.packed_data_id(0x01000000, "replace-object part id")
        return
    size = HOOK_PAYLOAD_SIZES.get(hook_type)
    if size is None:
        raise r.error(f"unknown animation hook type {hook_type} in a placement frame")
    r.skip(size, f"animation hook {hook_type}")


def _skip_locations(r: RecordReader, what: str) -> None:
    """An int count of (int key, LocationType: int part id + frame)."""
    count = r.count(r.i32(f"{what} count"), _MIN_LOCATION, what)
    r.skip(count * _MIN_LOCATION, what)


def parse_setup(data: bytes, *, path: str | None = None, file_id: int | None = None) -> dict[str, Any]:
    """Setup: id, flags, part count (uints); part GfxObj ids (uints); with flag
    0x1 a parent index per part (uints), with 0x2 a default scale per part (3
    floats); holding locations and connection points (int count, int key,
    int part, frame); placement frames (int count; int key, a frame per part,
    uint hook count and hooks); cylspheres and spheres (uint count each);
    height, radius, step-up and step-down heights (floats); sorting and
    selection spheres; lights (int count, int key, frame, color, intensity,
    falloff, cone angle); default animation, script, motion table, sound table
    and script table ids (uints).

    Returns the scene format's Setup dict.
    """
    r = RecordReader(data, path, file_id, "Setup")
    r.own_id()
    flags = r.u32("flags")
    num_parts = r.count(r.u32("part count"), 4, "part")
    parts = [dat_id_hex(p) for p in r.array("I", num_parts, "part ids")]
    if flags & SETUP_HAS_PARENT:
        r.skip(4 * num_parts, "parent indices")
    default_scale = None
    if flags & SETUP_HAS_DEFAULT_SCALE:
        default_scale = [r.vec3("default scale") for _ in range(num_parts)]
    _skip_locations(r, "holding location")
    _skip_locations(r, "connection point")
    num_placements = r.count(r.i32("placement count"), _MIN_PLACEMENT, "placement")
    placements: dict[str, dict[str, Any]] = {}
    for _ in range(num_placements):
        key = r.i32("placement id")
        frames = [read_frame(r, "placement frame") for _ in range(num_parts)]
        num_hooks = r.count(r.u32("placement hook count"), 8, "placement hook")
        for _ in range(num_hooks):
            _skip_hook(r)
        placements[str(key)] = {"frames": frames}
    cyl_spheres = [read_cyl_sphere(r) for _ in range(r.count(r.u32("cylsphere count"), 20, "cylsphere"))]
    spheres = [read_sphere(r) for _ in range(r.count(r.u32("sphere count"), 16, "sphere"))]
    out: dict[str, Any] = {"parts": parts, "placement_frames": placements}
    if default_scale is not None:
        out["default_scale"] = default_scale
    out["spheres"] = spheres
    out["cyl_spheres"] = cyl_spheres
    out["height"] = r.f32("height")
    out["radius"] = r.f32("radius")
    out["step_up_height"] = r.f32("step-up height")
    out["step_down_height"] = r.f32("step-down height")
    out["sorting_sphere"] = read_sphere(r, "sorting sphere")
    out["selection_sphere"] = read_sphere(r, "selection sphere")
    num_lights = r.count(r.i32("light count"), _MIN_LIGHT, "light")
    r.skip(num_lights * _MIN_LIGHT, "lights")
    r.skip(20, "default animation, script, motion, sound and script table ids")
    out["allow_free_heading"] = bool(flags & SETUP_ALLOW_FREE_HEADING)
    return out
