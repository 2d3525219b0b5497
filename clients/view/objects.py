"""What the live map draws of a landblock's buildings and static objects: their outlines from above.

The view opens the same world the service serves (`clients.view.terrain`
says why) and reads each loaded landblock's buildings (their shells) and
static objects (landblock and EnvCell statics) as the engine holds them, in
the shape the engine collides with: a part's physics BSP is drawn as the
convex hull of its polygons' corners seen from above; an object without one
as the circles of its cylinders, else of its spheres. Coordinates are global
metres (landblock column * 192 + local x, row * 192 + local y), as the page
draws everything else.
"""

from __future__ import annotations

import threading
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from engine.geometry import Vec3

from clients.view.terrain import LANDBLOCK_M, PerLandblock

__all__ = ["LandblockObjects", "ObjectSource", "Outline", "convex_hull"]


@dataclass(frozen=True, slots=True)
class Outline:
    """One building or object seen from above: a polygon (hull) and/or circles, global metres."""

    kind: str  # "building" or "object"
    polygon: tuple[tuple[float, float], ...] = ()  # counter-clockwise, empty when it has none
    circles: tuple[tuple[float, float, float], ...] = ()  # x, y, radius
    model: int | None = None  # a building's shell model (GfxObj id); the engine keeps none for static objects

    def to_json(self) -> dict[str, Any]:
        out: dict[str, Any] = {"kind": self.kind,
                               "polygon": [[round(x, 3), round(y, 3)] for x, y in self.polygon],
                               "circles": [[round(x, 3), round(y, 3), round(r, 3)] for x, y, r in self.circles]}
        if self.model is not None:
            out["model"] = f"{self.model:08X}"
        return out


@dataclass(frozen=True, slots=True)
class LandblockObjects:
    landblock: int
    outlines: list[Outline] = field(default_factory=list)

    def to_json(self) -> dict[str, Any]:
        return {"id": f"{self.landblock:04X}",
                "buildings": [o.to_json() for o in self.outlines if o.kind == "building"],
                "objects": [o.to_json() for o in self.outlines if o.kind == "object"]}


def convex_hull(points: Iterable[tuple[float, float]]) -> list[tuple[float, float]]:
    """The convex hull, counter-clockwise from the lowest-leftmost point (Andrew's monotone chain);
    collinear points left out."""
    pts = sorted(set(points))
    if len(pts) <= 2:
        return pts

    def cross(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple[float, float]] = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list[tuple[float, float]] = []
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return lower[:-1] + upper[:-1]


def _bsp_polygons(node: Any) -> Iterable[Any]:
    """Every polygon a BSP's nodes list (a polygon may be listed by more than one leaf)."""
    stack = [node]
    while stack:
        n = stack.pop()
        if n is None:
            continue
        yield from getattr(n, "polygons", ())
        stack.append(getattr(n, "pos_node", None))
        stack.append(getattr(n, "neg_node", None))


def _part_corners(part: Any) -> list[tuple[float, float]]:
    """The corners of a placed part's physics polygons, in its landblock's frame (x, y)."""
    bsp = part.gfx_obj.physics_bsp
    if bsp is None:
        return []
    s = part.gfx_scale
    frame = part.pos.frame
    corners = []
    for poly in _bsp_polygons(bsp.root_node):
        for v in poly.vertices:
            g = frame.local_to_global(Vec3(v.x * s.x, v.y * s.y, v.z * s.z))
            corners.append((g.x, g.y))
    return corners


def _circles(obj: Any) -> list[tuple[float, float, float]]:
    """An object without a physics BSP: its cylinders, else its spheres, placed and scaled (landblock frame)."""
    frame, scale = obj.position.frame, obj.scale
    if obj.cyl_spheres:
        shapes = [(c.low_point, c.radius) for c in obj.cyl_spheres]
    else:
        shapes = [(sp.center, sp.radius) for sp in obj.spheres]
    out = []
    for centre, radius in shapes:
        g = frame.local_to_global(Vec3(centre.x * scale, centre.y * scale, centre.z * scale))
        out.append((g.x, g.y, radius * scale))
    return out


def landblock_objects(landblock: Any) -> LandblockObjects:
    """The outlines of an engine Landblock's buildings and static objects, in global metres."""
    ox, oy = (landblock.id >> 8) * LANDBLOCK_M, (landblock.id & 0xFF) * LANDBLOCK_M

    def shift(points: Iterable[tuple[float, float]]) -> tuple[tuple[float, float], ...]:
        return tuple((ox + x, oy + y) for x, y in points)

    out: list[Outline] = []
    for b in landblock.buildings:
        corners = [c for part in b.parts[:1] for c in _part_corners(part)]  # the shell is part 0, as it collides
        if corners:
            out.append(Outline("building", polygon=shift(convex_hull(corners)), model=int(b.id)))
    for obj in landblock.objects:
        if obj.has_physics_bsp:
            obj.place_parts()
            corners = [c for part in obj.parts for c in _part_corners(part)]
            out.append(Outline("object", polygon=shift(convex_hull(corners))))
        else:
            circles = tuple((ox + x, oy + y, r) for x, y, r in _circles(obj))
            if circles:
                out.append(Outline("object", circles=circles))
    return LandblockObjects(landblock.id, out)


class ObjectSource:
    """Outlines per landblock from the view's world, worked out once each (thread-safe)."""

    def __init__(self, world: Any, lock: threading.Lock | None = None) -> None:
        self.world = world
        self._done = PerLandblock(self._outlines, lock)

    def objects(self, landblock: int) -> LandblockObjects | None:
        """The landblock's outlines, or None when the view's world has no such landblock."""
        return self._done.get(landblock)

    def _outlines(self, landblock: int) -> LandblockObjects | None:
        try:
            lb = self.world.load_landblock(landblock)
        except Exception:  # not in this world (a scene without it, a dat without it)
            return None
        return landblock_objects(lb)
