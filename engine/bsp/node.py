"""BSP nodes: internal nodes, leaves, portal nodes (the client's BSPNODE family).

One class hierarchy serves both kinds of tree the physics reads:

- a **physics BSP** (a cell structure's or a GfxObj's): every node has a
  bounding sphere, internal nodes have both children, leaves list the
  polygons to test and whether their region is solid;
- a **cell BSP** (which region of space a cell occupies): nodes carry a
  splitting plane and children only; the point / sphere / box-in-cell tests
  follow the positive children alone.

The recursive queries are methods, overridden by `BSPLeaf`, so traversal is
plain virtual dispatch. Nodes are immutable once built: each caches its
bounding sphere and splitting plane as floats, so the per-move path (the
bounding-sphere rejection and the plane distance at every node) allocates
nothing.

Leaves have no splitting plane of their own; as in the reference, their plane
is all zero, and the cell tests that are not overridden by leaves (point /
sphere / box in cell) evaluate it like any node: a point is "close" to it,
a sphere straddles it.

Results the reference returns through by-reference arguments are a returned
polygon (`find_walkable`) or fields of a `PolyHit` record that the caller
passes down (`sphere_intersects_poly`, `sphere_intersects_solid_poly`).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Final
from collections.abc import Iterator, Sequence

from ..constants import CELL_BSP_EPSILON, EPSILON
from ..geometry.plane import Plane
from ..geometry.polygon import Polygon, PolyHit
from ..geometry.sphere import Sphere
from ..geometry.vec3 import ZERO, Vec3

if TYPE_CHECKING:
    from ..transition.sphere_path import SpherePath
    from .bbox import BBox

__all__ = ["BoundingType", "BSPNode", "BSPLeaf", "BSPPortal", "PortalPoly"]


class BoundingType:
    """How a sphere lies against a cell BSP (the client's BoundingType)."""

    OUTSIDE: Final = 0
    PARTIALLY_INSIDE: Final = 1
    ENTIRELY_INSIDE: Final = 2


_ZERO_PLANE: Final = Plane(ZERO, 0.0)


class BSPNode:
    """An internal node: a splitting plane, its two sides, a bounding sphere.

    `pos_node` holds the side the plane's normal points to. `sphere` is None
    in cell BSPs (then the node never rejects a sphere by it). `type_name` is
    the dat tag (`BPIN`, `BPnN`, ...). `polygons` is empty for physics and
    cell nodes (only drawing BSPs list polygons at internal nodes).
    """

    __slots__ = (
        "sphere",
        "splitting_plane",
        "type_name",
        "poly_ids",
        "polygons",
        "num_polys",
        "pos_node",
        "neg_node",
        "_sx",
        "_sy",
        "_sz",
        "_sr",
        "_nx",
        "_ny",
        "_nz",
        "_d",
    )

    sphere: Sphere | None
    splitting_plane: Plane
    type_name: str
    poly_ids: tuple[int, ...]
    polygons: tuple[Polygon, ...]
    num_polys: int
    pos_node: BSPNode | None
    neg_node: BSPNode | None

    def __init__(
        self,
        splitting_plane: Plane,
        pos_node: BSPNode | None,
        neg_node: BSPNode | None,
        sphere: Sphere | None = None,
        polygons: Sequence[Polygon] = (),
        poly_ids: Sequence[int] | None = None,
        type_name: str = "BPnN",
    ) -> None:
        self.splitting_plane = splitting_plane
        self.pos_node = pos_node
        self.neg_node = neg_node
        self.type_name = type_name
        self._set_polygons(polygons, poly_ids)
        self._set_sphere(sphere)
        n = splitting_plane.normal
        self._nx, self._ny, self._nz, self._d = n.x, n.y, n.z, splitting_plane.d

    def _set_polygons(self, polygons: Sequence[Polygon], poly_ids: Sequence[int] | None) -> None:
        self.polygons = tuple(polygons)
        self.num_polys = len(self.polygons)
        self.poly_ids = tuple(poly_ids) if poly_ids is not None else tuple(p.poly_id for p in self.polygons)

    def _set_sphere(self, sphere: Sphere | None) -> None:
        self.sphere = sphere
        if sphere is None:
            self._sx = self._sy = self._sz = 0.0
            self._sr = math.inf
        else:
            c = sphere.center
            self._sx, self._sy, self._sz, self._sr = c.x, c.y, c.z, sphere.radius

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self.type_name}, plane={self.splitting_plane!r}, sphere={self.sphere!r})"

    def is_leaf(self) -> bool:
        return False

    def iter_nodes(self) -> Iterator[BSPNode]:
        """This node and every node below it, positive side first."""
        stack: list[BSPNode] = [self]
        while stack:
            node = stack.pop()
            yield node
            if node.neg_node is not None:
                stack.append(node.neg_node)
            if node.pos_node is not None:
                stack.append(node.pos_node)

    # -- physics queries ----------------------------------------------------
    def sphere_intersects_poly(self, check_pos: Sphere, movement: Vec3, hit: PolyHit) -> bool:
        """Does the sphere, moving by `movement`, run into a polygon below
        this node? (BSPNODE::sphere_intersects_poly)

        Sides the sphere reaches (within its radius less EPSILON) are
        searched, positive first. `hit` receives the polygon and contact
        point (see `Polygon.pos_hits_sphere`).
        """
        c = check_pos.center
        r = check_pos.radius
        dx = c.x - self._sx
        dy = c.y - self._sy
        dz = c.z - self._sz
        rs = self._sr + r
        if not (dx * dx + dy * dy + dz * dz < rs * rs):
            return False
        dist = self._nx * c.x + self._ny * c.y + self._nz * c.z + self._d
        reach = r - EPSILON
        if dist >= reach:
            return self.pos_node.sphere_intersects_poly(check_pos, movement, hit)  # type: ignore[union-attr]
        if dist <= -reach:
            return self.neg_node.sphere_intersects_poly(check_pos, movement, hit)  # type: ignore[union-attr]
        pos = self.pos_node
        if pos is not None and pos.sphere_intersects_poly(check_pos, movement, hit):
            return True
        neg = self.neg_node
        if neg is not None and neg.sphere_intersects_poly(check_pos, movement, hit):
            return True
        return False

    def sphere_intersects_solid(self, check_pos: Sphere, center_check: bool) -> bool:
        """Does the sphere touch a polygon, or (with `center_check`) have its
        center in a solid leaf? (BSPNODE::sphere_intersects_solid)

        When the sphere straddles the plane, the center check is passed on
        only to the side the center is on.
        """
        c = check_pos.center
        r = check_pos.radius
        dx = c.x - self._sx
        dy = c.y - self._sy
        dz = c.z - self._sz
        rs = self._sr + r
        if not (dx * dx + dy * dy + dz * dz < rs * rs):
            return False
        dist = self._nx * c.x + self._ny * c.y + self._nz * c.z + self._d
        reach = r - EPSILON
        if dist >= reach:
            return self.pos_node.sphere_intersects_solid(check_pos, center_check)  # type: ignore[union-attr]
        if dist <= -reach:
            return self.neg_node.sphere_intersects_solid(check_pos, center_check)  # type: ignore[union-attr]
        if dist < 0.0:
            if self.pos_node.sphere_intersects_solid(check_pos, False):  # type: ignore[union-attr]
                return True
            return self.neg_node.sphere_intersects_solid(check_pos, center_check)  # type: ignore[union-attr]
        if self.pos_node.sphere_intersects_solid(check_pos, center_check):  # type: ignore[union-attr]
            return True
        return self.neg_node.sphere_intersects_solid(check_pos, False)  # type: ignore[union-attr]

    def sphere_intersects_solid_poly(self, check_pos: Sphere, radius: float, hit: PolyHit, center_check: bool) -> bool:
        """Placement's solid test (BSPNODE::sphere_intersects_solid_poly).

        Like `sphere_intersects_solid`, but the side test uses `radius`
        (which placement grows) and the touched polygon and the center-in-
        solid flag are reported in `hit.poly` / `hit.center_solid`. When the
        sphere straddles the plane, the center's side is searched first; if
        a polygon is known after that (also one left in `hit` by an earlier
        query), the answer is `hit.center_solid` and the other side is not
        searched.
        """
        c = check_pos.center
        dx = c.x - self._sx
        dy = c.y - self._sy
        dz = c.z - self._sz
        rs = self._sr + check_pos.radius
        if not (dx * dx + dy * dy + dz * dz < rs * rs):
            return False
        dist = self._nx * c.x + self._ny * c.y + self._nz * c.z + self._d
        reach = radius - EPSILON
        if dist >= reach:
            return self.pos_node.sphere_intersects_solid_poly(check_pos, radius, hit, center_check)  # type: ignore[union-attr]
        if dist <= -reach:
            return self.neg_node.sphere_intersects_solid_poly(check_pos, radius, hit, center_check)  # type: ignore[union-attr]
        if dist <= 0.0:
            self.neg_node.sphere_intersects_solid_poly(check_pos, radius, hit, center_check)  # type: ignore[union-attr]
            if hit.poly is not None:
                return hit.center_solid
            return self.pos_node.sphere_intersects_solid_poly(check_pos, radius, hit, False)  # type: ignore[union-attr]
        self.pos_node.sphere_intersects_solid_poly(check_pos, radius, hit, center_check)  # type: ignore[union-attr]
        if hit.poly is not None:
            return hit.center_solid
        return self.neg_node.sphere_intersects_solid_poly(check_pos, radius, hit, False)  # type: ignore[union-attr]

    def find_walkable(self, path: SpherePath, valid_pos: Sphere, movement: Vec3, up: Vec3) -> Polygon | None:
        """Settle `valid_pos` onto walkable polygons it overlaps, backing it
        along `movement` (BSPNODE::find_walkable).

        Moves `valid_pos` in place and lowers `path.walk_interp` for every
        polygon it is adjusted to; returns the last such polygon, or None
        when nothing changed. A straddling sphere visits the positive side,
        then the negative side with its possibly moved position.
        """
        c = valid_pos.center
        r = valid_pos.radius
        dx = c.x - self._sx
        dy = c.y - self._sy
        dz = c.z - self._sz
        rs = self._sr + r
        if not (dx * dx + dy * dy + dz * dz < rs * rs):
            return None
        dist = self._nx * c.x + self._ny * c.y + self._nz * c.z + self._d
        reach = r - EPSILON
        if dist >= reach:
            return self.pos_node.find_walkable(path, valid_pos, movement, up)  # type: ignore[union-attr]
        if dist <= -reach:
            return self.neg_node.find_walkable(path, valid_pos, movement, up)  # type: ignore[union-attr]
        first = self.pos_node.find_walkable(path, valid_pos, movement, up)  # type: ignore[union-attr]
        second = self.neg_node.find_walkable(path, valid_pos, movement, up)  # type: ignore[union-attr]
        return second if second is not None else first

    def hits_walkable(self, path: SpherePath, valid_pos: Sphere, up: Vec3) -> bool:
        """Does the sphere rest on a walkable polygon? (BSPNODE::hits_walkable)"""
        c = valid_pos.center
        r = valid_pos.radius
        dx = c.x - self._sx
        dy = c.y - self._sy
        dz = c.z - self._sz
        rs = self._sr + r
        if not (dx * dx + dy * dy + dz * dz < rs * rs):
            return False
        dist = self._nx * c.x + self._ny * c.y + self._nz * c.z + self._d
        reach = r - EPSILON
        if dist >= reach:
            return self.pos_node.hits_walkable(path, valid_pos, up)  # type: ignore[union-attr]
        if dist <= -reach:
            return self.neg_node.hits_walkable(path, valid_pos, up)  # type: ignore[union-attr]
        if self.pos_node.hits_walkable(path, valid_pos, up):  # type: ignore[union-attr]
            return True
        if self.neg_node.hits_walkable(path, valid_pos, up):  # type: ignore[union-attr]
            return True
        return False

    def point_intersects_solid(self, point: Vec3) -> bool:
        """Is the point in a leaf that has polygons?
        (BSPNODE::point_intersects_solid; a point on the plane goes negative)"""
        if point.x * self._nx + point.y * self._ny + point.z * self._nz + self._d > 0.0:
            return self.pos_node.point_intersects_solid(point)  # type: ignore[union-attr]
        return self.neg_node.point_intersects_solid(point)  # type: ignore[union-attr]

    # -- cell queries (positive chain only) ----------------------------------
    def point_inside_cell_bsp(self, point: Vec3) -> bool:
        """Is the point in front of (or within EPSILON of) every plane along
        the positive chain? (BSPNODE::point_inside_cell_bsp)"""
        node: BSPNode | None = self
        px, py, pz = point.x, point.y, point.z
        while node is not None:
            dist = node._nx * px + node._ny * py + node._nz * pz + node._d
            if dist < -EPSILON:  # Side.BEHIND
                return False
            node = node.pos_node
        return True

    def sphere_intersects_cell_bsp(self, sphere: Sphere) -> int:
        """Classify a sphere against the cell (BSPNODE::sphere_intersects_cell_bsp).

        Planes are given 0.01 m of slack. OUTSIDE as soon as the sphere is
        wholly behind a plane of the positive chain; ENTIRELY_INSIDE only if
        it is wholly in front of every plane down to a node without positive
        child, else PARTIALLY_INSIDE. (A leaf ending the chain has the zero
        plane, which every sphere straddles: with leaves, the best answer is
        PARTIALLY_INSIDE, as in the reference.)
        """
        # Walked as a loop: a straddled plane turns a later ENTIRELY_INSIDE
        # into PARTIALLY_INSIDE, and OUTSIDE anywhere down the chain wins.
        c = sphere.center
        cx, cy, cz = c.x, c.y, c.z
        check_rad = sphere.radius + CELL_BSP_EPSILON
        straddled = False
        node: BSPNode = self
        while True:
            dist = node._nx * cx + node._ny * cy + node._nz * cz + node._d
            if dist <= -check_rad:
                return BoundingType.OUTSIDE
            if not dist >= check_rad:
                straddled = True
            pos = node.pos_node
            if pos is None:
                return BoundingType.PARTIALLY_INSIDE if straddled else BoundingType.ENTIRELY_INSIDE
            node = pos

    def box_intersects_cell_bsp(self, box: BBox) -> bool:
        """False when some plane of the positive chain has the whole box
        behind it (BSPNODE::box_intersects_cell_bsp).

        A plane is only examined when the box's min corner is behind it
        (more than EPSILON); then all eight corners must be behind.
        """
        corners = box.get_corners()
        bmin = box.min
        node: BSPNode | None = self
        while node is not None:
            nx, ny, nz, d = node._nx, node._ny, node._nz, node._d
            if bmin.x * nx + bmin.y * ny + bmin.z * nz + d >= -EPSILON:
                node = node.pos_node
                continue
            for corner in corners:
                if not (nx * corner.x + ny * corner.y + nz * corner.z + d < -EPSILON):
                    break
            else:
                return False
            node = node.pos_node
        return True


class BSPLeaf(BSPNode):
    """A leaf: the polygons of its region and whether the region is solid.

    `solid` is only read by placement and ethereal checks, and only when the
    leaf has polygons. A leaf of a cell BSP has neither sphere nor polygons.
    """

    __slots__ = ("leaf_index", "solid")

    leaf_index: int
    solid: bool

    def __init__(
        self,
        leaf_index: int,
        polygons: Sequence[Polygon] = (),
        sphere: Sphere | None = None,
        solid: bool = False,
        poly_ids: Sequence[int] | None = None,
    ) -> None:
        super().__init__(_ZERO_PLANE, None, None, sphere, polygons, poly_ids, "LEAF")
        self.leaf_index = leaf_index
        self.solid = solid

    def __repr__(self) -> str:
        return f"BSPLeaf({self.leaf_index}, solid={self.solid}, polys={list(self.poly_ids)}, sphere={self.sphere!r})"

    def is_leaf(self) -> bool:
        return True

    def sphere_intersects_poly(self, check_pos: Sphere, movement: Vec3, hit: PolyHit) -> bool:
        """BSPLEAF::sphere_intersects_poly: the first polygon the moving
        sphere runs into answers True."""
        if self.num_polys == 0:
            return False
        c = check_pos.center
        dx = c.x - self._sx
        dy = c.y - self._sy
        dz = c.z - self._sz
        rs = self._sr + check_pos.radius
        if not (dx * dx + dy * dy + dz * dz < rs * rs):
            return False
        for poly in self.polygons:
            if poly.pos_hits_sphere(check_pos, movement, hit):
                return True
        return False

    def sphere_intersects_solid(self, check_pos: Sphere, center_check: bool) -> bool:
        """BSPLEAF::sphere_intersects_solid: a solid leaf holds the center
        (when asked), or the sphere touches one of its polygons."""
        if self.num_polys == 0:
            return False
        if center_check and self.solid:
            return True
        c = check_pos.center
        dx = c.x - self._sx
        dy = c.y - self._sy
        dz = c.z - self._sz
        rs = self._sr + check_pos.radius
        if not (dx * dx + dy * dy + dz * dz < rs * rs):
            return False
        for poly in self.polygons:
            if poly.hits_sphere(check_pos):
                return True
        return False

    def sphere_intersects_solid_poly(self, check_pos: Sphere, radius: float, hit: PolyHit, center_check: bool) -> bool:
        """BSPLEAF::sphere_intersects_solid_poly: records a solid center in
        `hit.center_solid`; True with `hit.poly` set for the first polygon
        touched, else the center-solid flag."""
        if self.num_polys == 0:
            return False
        if center_check and self.solid:
            hit.center_solid = True
        c = check_pos.center
        dx = c.x - self._sx
        dy = c.y - self._sy
        dz = c.z - self._sz
        rs = self._sr + check_pos.radius
        if not (dx * dx + dy * dy + dz * dz < rs * rs):
            return hit.center_solid
        for poly in self.polygons:
            if poly.hits_sphere(check_pos):
                hit.poly = poly
                return True
        return hit.center_solid

    def find_walkable(self, path: SpherePath, valid_pos: Sphere, movement: Vec3, up: Vec3) -> Polygon | None:
        """BSPLEAF::find_walkable: every walkable polygon the sphere touches
        (in order, with the sphere as moved by the ones before) may settle
        it; the last that does is returned."""
        if self.num_polys == 0:
            return None
        c = valid_pos.center
        dx = c.x - self._sx
        dy = c.y - self._sy
        dz = c.z - self._sz
        rs = self._sr + valid_pos.radius
        if not (dx * dx + dy * dy + dz * dz < rs * rs):
            return None
        found = None
        for poly in self.polygons:
            if poly.walkable_hits_sphere(path, valid_pos, up) and poly.adjust_sphere_to_plane(path, valid_pos, movement):
                found = poly
        return found

    def hits_walkable(self, path: SpherePath, valid_pos: Sphere, up: Vec3) -> bool:
        """BSPLEAF::hits_walkable: a walkable polygon touches the sphere and
        holds up its smaller (half-radius) footprint."""
        if self.num_polys == 0:
            return False
        c = valid_pos.center
        dx = c.x - self._sx
        dy = c.y - self._sy
        dz = c.z - self._sz
        rs = self._sr + valid_pos.radius
        if not (dx * dx + dy * dy + dz * dz < rs * rs):
            return False
        for poly in self.polygons:
            if poly.walkable_hits_sphere(path, valid_pos, up) and poly.check_small_walkable(valid_pos, up):
                return True
        return False

    def point_intersects_solid(self, point: Vec3) -> bool:
        """BSPLEAF::point_intersects_solid: a leaf with polygons is solid
        here (the solid flag is not consulted)."""
        return self.num_polys != 0


class PortalPoly:
    """A portal polygon of a drawing BSP portal node (the client's CPortalPoly)."""

    __slots__ = ("portal_index", "portal")

    portal_index: int
    portal: Polygon | None

    def __init__(self, portal_index: int = -1, portal: Polygon | None = None) -> None:
        self.portal_index = portal_index
        self.portal = portal

    def __repr__(self) -> str:
        return f"PortalPoly({self.portal_index}, {self.portal!r})"


class BSPPortal(BSPNode):
    """A portal node (`PORT`): an internal node of a drawing BSP that also
    lists portal polygons. Physics and cell BSPs never contain one; for the
    physics queries it is an ordinary internal node."""

    __slots__ = ("portals",)

    portals: list[PortalPoly]

    def __init__(
        self,
        splitting_plane: Plane,
        pos_node: BSPNode | None,
        neg_node: BSPNode | None,
        sphere: Sphere | None = None,
        polygons: Sequence[Polygon] = (),
        poly_ids: Sequence[int] | None = None,
        portals: Sequence[PortalPoly] = (),
    ) -> None:
        super().__init__(splitting_plane, pos_node, neg_node, sphere, polygons, poly_ids, "PORT")
        self.portals = list(portals)

    @property
    def num_portals(self) -> int:
        return len(self.portals)
