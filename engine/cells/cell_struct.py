"""CellStruct: an indoor cell's geometry (one of an Environment's cell structs)."""

from __future__ import annotations

from typing import Any
from collections.abc import Mapping

from ..bsp import build_bsp, build_polygons
from ..bsp.bbox import BBox
from ..bsp.tree import BSPTree
from ..geometry import Sphere, Vec3
from ..geometry.polygon import Polygon

__all__ = ["CellStruct"]


class CellStruct:
    """Drawing polygons (for portals), physics polygons, the cell BSP that
    decides membership and the physics BSP that movers collide with."""

    __slots__ = ("polygons", "portals", "physics_polygons", "cell_bsp", "physics_bsp")

    def __init__(
        self,
        polygons: dict[int, Polygon],
        portals: list[Polygon],
        physics_polygons: dict[int, Polygon],
        cell_bsp: BSPTree | None,
        physics_bsp: BSPTree | None,
    ) -> None:
        self.polygons = polygons
        self.portals = portals
        self.physics_polygons = physics_polygons
        self.cell_bsp = cell_bsp
        self.physics_bsp = physics_bsp

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> CellStruct:
        """Build from an acphys-scene/1 CellStruct dict."""
        vertices = d.get("vertices", {})
        polygons = build_polygons(d.get("polygons", {}), vertices)
        physics_polygons = build_polygons(d.get("physics_polygons", {}), vertices)
        portals = [polygons[int(i)] for i in d.get("portals", [])]
        cell_bsp = build_bsp(d["cell_bsp"], physics_polygons) if d.get("cell_bsp") else None
        physics_bsp = build_bsp(d["physics_bsp"], physics_polygons) if d.get("physics_bsp") else None
        return cls(polygons, portals, physics_polygons, cell_bsp, physics_bsp)

    # -- membership (pos-node-only cell BSP tests) ----------------------------
    def point_in_cell(self, point: Vec3) -> bool:
        return self.cell_bsp is not None and self.cell_bsp.point_inside_cell_bsp(point)

    def sphere_intersects_cell(self, sphere: Sphere) -> int:
        if self.cell_bsp is None:
            return 0  # BoundingType.OUTSIDE
        return self.cell_bsp.sphere_intersects_cell_bsp(sphere)

    def box_intersects_cell(self, box: BBox) -> bool:
        return self.cell_bsp is not None and self.cell_bsp.box_intersects_cell_bsp(box)
