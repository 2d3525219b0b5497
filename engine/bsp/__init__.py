"""BSP trees of physics geometry: nodes, leaves, the tree's queries, builders.

- `BSPTree` (tree.py): find_collisions, placement_insert, step_sphere_up /
  step_sphere_down, collide_with_pt, adjust_to_plane and the cell BSP tests.
- `BSPNode` / `BSPLeaf` / `BSPPortal` (node.py): the recursive queries.
- `BBox`, `intersect_box` (bbox.py): boxes against cell BSPs and planes.
- `build_polygons`, `build_bsp` (build.py): from `acphys-scene/1` dicts.
"""

from .bbox import BBox, intersect_box
from .build import build_bsp, build_polygons, build_vertices
from .node import BoundingType, BSPLeaf, BSPNode, BSPPortal, PortalPoly
from .tree import BSPTree, plane_local_to_global

__all__ = [
    "BBox",
    "intersect_box",
    "build_bsp",
    "build_polygons",
    "build_vertices",
    "BoundingType",
    "BSPLeaf",
    "BSPNode",
    "BSPPortal",
    "PortalPoly",
    "BSPTree",
    "plane_local_to_global",
]
