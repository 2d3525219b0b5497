"""Build polygons and BSP trees from `acphys-scene/1` dictionaries.

The scene format mirrors the dat files (see the formats README, section
"indoor cells, buildings and objects"): vertices `{"id": [x, y, z]}`,
polygons `{"id": {"vertex_ids", "sides_type", ...}}`, and BSP nodes tagged
with the client's four-letter types. Children are read as the dat reader
reads them: `BPnn`/`BPIn` have a positive child only, `BpIN`/`BpnN` a
negative child only, `BPIN`/`BPnN`/`PORT` both.
"""

from __future__ import annotations

from typing import Any, Final
from collections.abc import Mapping

from ..geometry.plane import Plane
from ..geometry.polygon import Polygon
from ..geometry.sphere import Sphere
from ..geometry.vec3 import Vec3
from .node import BSPLeaf, BSPNode, BSPPortal, PortalPoly
from .tree import BSPTree

__all__ = ["build_polygons", "build_bsp", "build_vertices"]

_POS_ONLY: Final = frozenset(("BPnn", "BPIn"))
_NEG_ONLY: Final = frozenset(("BpIN", "BpnN"))
_BOTH: Final = frozenset(("BPIN", "BPnN"))


def build_vertices(vertices_dict: Mapping[Any, Any]) -> dict[int, Vec3]:
    """A CVertexArray: `{"0": [x, y, z], ...}` -> {0: Vec3, ...}."""
    return {int(k): Vec3(float(v[0]), float(v[1]), float(v[2])) for k, v in vertices_dict.items()}


def build_polygons(polys_dict: Mapping[Any, Any], vertices_dict: Mapping[Any, Any]) -> dict[int, Polygon]:
    """Polygons keyed by their dat id, with planes computed (make_plane).

    `vertices_dict` is the owner's vertex array (raw scene dict, or already
    built by `build_vertices`). Vertex ids are read as the dat's unsigned
    shorts. `poly_id` is set to the polygon's key.
    """
    verts: dict[int, Vec3] = {}
    for k, v in vertices_dict.items():
        verts[int(k)] = v if isinstance(v, Vec3) else Vec3(float(v[0]), float(v[1]), float(v[2]))
    polygons: dict[int, Polygon] = {}
    for key, pd in polys_dict.items():
        pid = int(key)
        ids = [int(i) for i in pd["vertex_ids"]]
        try:
            points = [verts[i & 0xFFFF] for i in ids]
        except KeyError as e:
            raise ValueError(f"polygon {pid} names vertex {e.args[0]}, which the vertex array lacks") from None
        if len(points) < 3:
            raise ValueError(f"polygon {pid} has {len(points)} vertices; a polygon needs at least 3")
        polygons[pid] = Polygon(
            points,
            int(pd.get("sides_type", 0)),
            vertex_ids=ids,
            poly_id=pid,
            stippling=int(pd.get("stippling", 0)),
            pos_surface=int(pd.get("pos_surface", 0)),
            neg_surface=int(pd.get("neg_surface", -1)),
        )
    return polygons


def _plane(d: Mapping[str, Any]) -> Plane:
    n = d["normal"]
    return Plane(Vec3(float(n[0]), float(n[1]), float(n[2])), float(d["d"]))


def _sphere(d: Mapping[str, Any] | None) -> Sphere | None:
    if d is None:
        return None
    o = d["origin"] if "origin" in d else d["center"]
    return Sphere(Vec3(float(o[0]), float(o[1]), float(o[2])), float(d["radius"]))


def _polys(node: Mapping[str, Any], polygons: Mapping[int, Polygon]) -> tuple[list[Polygon], list[int]]:
    ids = [int(i) for i in node.get("in_polys") or ()]
    try:
        return [polygons[i] for i in ids], ids
    except KeyError as e:
        raise ValueError(f"BSP node lists polygon {e.args[0]}, which the polygon table lacks") from None


def _portal_poly(entry: Any, polygons: Mapping[int, Polygon]) -> PortalPoly:
    """A drawing portal entry: `[portal_index, polygon_id]` as the dat stores
    it, or `{"portal_index", "polygon_id"}`."""
    if isinstance(entry, Mapping):
        index, poly_id = int(entry.get("portal_index", -1)), int(entry["polygon_id"])
    else:
        index, poly_id = int(entry[0]), int(entry[1])
    return PortalPoly(index, polygons.get(poly_id))


def _build_node(node: Mapping[str, Any], polygons: Mapping[int, Polygon], physics: bool, path: str) -> BSPNode:
    tag = node["type"]
    if tag == "LEAF":
        polys, ids = _polys(node, polygons)
        return BSPLeaf(int(node.get("leaf_index", -1)), polys, _sphere(node.get("sphere")), bool(node.get("solid", 0)), ids)

    if tag in _BOTH or tag == "PORT":
        want_pos = want_neg = True
    elif tag in _POS_ONLY:
        want_pos, want_neg = True, False
    elif tag in _NEG_ONLY:
        want_pos, want_neg = False, True
    else:
        raise ValueError(f"BSP node at {path} has unknown type {tag!r}")

    pos = neg = None
    if want_pos:
        if node.get("pos_node") is None:
            raise ValueError(f"BSP node {tag} at {path} lacks its pos_node")
        pos = _build_node(node["pos_node"], polygons, physics, path + ".pos")
    if want_neg:
        if node.get("neg_node") is None:
            raise ValueError(f"BSP node {tag} at {path} lacks its neg_node")
        neg = _build_node(node["neg_node"], polygons, physics, path + ".neg")
    if physics and (pos is None or neg is None):
        raise ValueError(
            f"physics BSP node {tag} at {path} has one child; physics traversal needs both (BPIN / BPnN)"
        )

    plane = _plane(node["splitting_plane"])
    sphere = _sphere(node.get("sphere"))
    polys, ids = _polys(node, polygons)
    if tag == "PORT":
        portals = [_portal_poly(p, polygons) for p in node.get("in_portals") or ()]
        return BSPPortal(plane, pos, neg, sphere, polys, ids, portals)
    return BSPNode(plane, pos, neg, sphere, polys, ids, tag)


def build_bsp(node_dict: Mapping[str, Any], polygons: Mapping[int, Polygon] | None = None) -> BSPTree:
    """A BSPTree from a scene BSP node dict.

    Physics BSPs (nodes with bounding spheres; leaves listing polygons that
    `polygons` must hold: a cell struct's or GfxObj's `physics_polygons`,
    built with `build_polygons`) and cell BSPs (planes and children only;
    `polygons` may be omitted) are both accepted. A physics BSP node with
    one child is rejected, since the physics traversal follows both sides.

    A tree whose root is a LEAF gets a BSPLeaf root, which answers queries
    as the client's leaf does. (ACE would wrap such a root in a childless
    internal node; no scene has one.)
    """
    physics = "sphere" in node_dict
    return BSPTree(_build_node(node_dict, polygons or {}, physics, "root"))
