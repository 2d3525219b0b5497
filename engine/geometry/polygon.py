"""Polygons of physics geometry and the client's polygon-level collision tests.

A `Polygon` is a convex, planar vertex loop (counter-clockwise seen from the
front) with the plane the client derives from it (`Plane.from_points`, the
client's `CPolygon::make_plane`): the faces of cell structures' and objects'
physics BSPs, and terrain triangles built as `Polygon([v0, v1, v2])` (the
default sides_type 0 is the terrain's single-sided CullMode).

Every test here follows the reference implementation branch for branch and
in the same order, including its epsilons; only the spelling is Python's.
Out-parameters of the reference become return values, or a `PolyHit` record
that plays the part of the reference's `ref` arguments when a routine both
answers and reports (hit polygon, contact point, "center is in solid").

Per-edge data the tests need on every call (the edge's start vertex, the edge
vector, the in-plane edge normal `cross(plane normal, edge)` and both squared
lengths) is computed once in `make_plane`; the values are the ones the
reference recomputes per call, so the answers are unchanged.

Argument order is the reference's: path (when used) first, then spheres, then
vectors, e.g. `check_walkable(sphere, up)`, `walkable_hits_sphere(path, sphere,
up)`, `adjust_sphere_to_plane(path, valid_pos, movement)`.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Final
from collections.abc import Sequence

from ..constants import EPSILON
from .plane import Plane
from .sphere import Sphere
from .vec3 import ZERO, Vec3

if TYPE_CHECKING:
    from ..transition.sphere_path import SpherePath

__all__ = ["CullMode", "Polygon", "PolyHit", "Ray"]


class CullMode:
    """The dat's polygon `sides_type` (ACE `CullMode`).

    LANDBLOCK (0) is single-sided: the only value the physics tests read, in
    `polygon_hits_ray`, where a ray leaving through the back is ignored.
    """

    LANDBLOCK: Final = 0
    NONE: Final = 1
    CLOCKWISE: Final = 2
    COUNTER_CLOCKWISE: Final = 3


class PolyHit:
    """What a polygon or BSP query reports besides its boolean answer.

    Stands in for the reference's by-reference arguments, so it keeps their
    semantics: a query only ever *writes* these fields, and a caller that
    reuses one record across queries sees earlier values survive, exactly as a
    reused reference variable does.

    - `poly`: the polygon the sphere touched. `pos_hits_sphere` sets it on any
      touch, also when the sphere moves away from the polygon and the query
      answers False (the "overlapping but not intersecting" polygon).
    - `contact_point`: the sphere center projected onto the plane of the last
      polygon whose plane the sphere reached.
    - `center_solid`: the sphere center lies in a solid leaf
      (`sphere_intersects_solid_poly`).
    """

    __slots__ = ("poly", "contact_point", "center_solid")

    poly: Polygon | None
    contact_point: Vec3
    center_solid: bool


    def found(self) -> Polygon | None:
        """The polygon a query recorded (a plain read that no caller narrows)."""
        return self.poly

    def __init__(self) -> None:
        self.poly = None
        self.contact_point = ZERO
        self.center_solid = False

    def __repr__(self) -> str:
        return f"PolyHit(poly={self.poly!r}, contact_point={self.contact_point!r}, center_solid={self.center_solid})"


class Ray:
    """A ray: start point, unit direction and length (ACE `Ray`)."""

    __slots__ = ("point", "dir", "length")

    point: Vec3
    dir: Vec3
    length: float

    def __init__(self, point: Vec3 = ZERO, direction: Vec3 = ZERO, length: float = 0.0) -> None:
        self.point = point
        self.dir = direction
        self.length = length

    @classmethod
    def from_offset(cls, start_point: Vec3, offset: Vec3) -> Ray:
        """The reference's Ray(startPoint, offset) constructor.

        It normalises `offset` into the direction when `offset` differs from
        `start_point` by more than EPSILON on some axis (the reference
        compares the two vectors, not the offset with zero); otherwise the
        ray stays all zero.
        """
        ray = cls()
        if (
            abs(offset.x - start_point.x) > EPSILON
            or abs(offset.y - start_point.y) > EPSILON
            or abs(offset.z - start_point.z) > EPSILON
        ):
            length = math.sqrt(offset.x * offset.x + offset.y * offset.y + offset.z * offset.z)
            inv = 1.0 / length
            ray.length = length
            ray.point = start_point
            ray.dir = Vec3(offset.x * inv, offset.y * inv, offset.z * inv)
        return ray

    def __repr__(self) -> str:
        return f"Ray({self.point!r}, {self.dir!r}, {self.length!r})"


class PolyEdge:
    """One edge's cached data, as native floats: the start vertex (lx, ly, lz),
    the edge vector (ex, ey, ez), the in-plane edge normal k = n x e (kx, ky,
    kz), |k|^2 (kk) and |e|^2 (ee). The edge runs from the previous vertex to
    the current one; the first edge starts at the last vertex."""

    __slots__ = ("lx", "ly", "lz", "ex", "ey", "ez", "kx", "ky", "kz", "kk", "ee")

    lx: float
    ly: float
    lz: float
    ex: float
    ey: float
    ez: float
    kx: float
    ky: float
    kz: float
    kk: float
    ee: float

    def __init__(self, lx: float, ly: float, lz: float, ex: float, ey: float, ez: float,
                 kx: float, ky: float, kz: float, kk: float, ee: float) -> None:
        self.lx = lx
        self.ly = ly
        self.lz = lz
        self.ex = ex
        self.ey = ey
        self.ez = ez
        self.kx = kx
        self.ky = ky
        self.kz = kz
        self.kk = kk
        self.ee = ee


#: How a circle in a polygon's plane stands to its edges (`circle_on_edges`).
CIRCLE_MISSES: Final = 0
CIRCLE_TOUCHES: Final = 1
CIRCLE_INSIDE: Final = 2


def circle_on_edges(edges: tuple[PolyEdge, ...], px: float, py: float, pz: float, r2: float, stop_outside: bool) -> int:
    """Where a circle of squared radius `r2` about the in-plane point p stands
    to a polygon, edge by edge in order: the edge walk the client's
    sphere-in-polygon tests share (hits_sphere, polygon_hits_sphere,
    check_walkable).

    CIRCLE_MISSES at once when p is outside an edge by more than r;
    CIRCLE_TOUCHES at once when the circle reaches an edge segment p is
    outside of, or an edge's start vertex. Outside an edge otherwise: MISSES
    at once with `stop_outside`, else MISSES at the end if nothing touched.
    CIRCLE_INSIDE when p is inside every edge and touches nothing.
    """
    outside = False
    for edge in edges:
        dx = px - edge.lx
        dy = py - edge.ly
        dz = pz - edge.lz
        dp = dx * edge.kx + dy * edge.ky + dz * edge.kz
        if dp < 0.0:
            if edge.kk * r2 < dp * dp:
                return CIRCLE_MISSES
            disp_edge = dx * edge.ex + dy * edge.ey + dz * edge.ez
            if disp_edge >= 0.0 and disp_edge <= edge.ee:
                return CIRCLE_TOUCHES
            if stop_outside:
                return CIRCLE_MISSES
            outside = True
        if dx * dx + dy * dy + dz * dz <= r2:
            return CIRCLE_TOUCHES
    return CIRCLE_MISSES if outside else CIRCLE_INSIDE

class Polygon:
    """A physics polygon (the client's CPolygon).

    `vertices` are in the owner's local frame (cell, part or landblock).
    `sides_type` is the dat CullMode (0 = single-sided, the terrain default).
    The other dat fields are carried for completeness; physics ignores them.
    After changing `vertices` in place, call `make_plane()`.
    """

    __slots__ = (
        "vertices",
        "vertex_ids",
        "num_points",
        "sides_type",
        "stippling",
        "pos_surface",
        "neg_surface",
        "poly_id",
        "plane",
        "_nx",
        "_ny",
        "_nz",
        "_d",
        "_edges",
    )

    vertices: list[Vec3]
    vertex_ids: list[int]
    num_points: int
    sides_type: int
    stippling: int
    pos_surface: int
    neg_surface: int
    poly_id: int
    plane: Plane
    _nx: float
    _ny: float
    _nz: float
    _d: float
    #: per edge: last vertex, edge vector, inward edge normal k = n x e, |k|^2, |e|^2
    _edges: tuple[PolyEdge, ...]

    def __init__(
        self,
        vertices: Sequence[Vec3],
        sides_type: int = CullMode.LANDBLOCK,
        *,
        vertex_ids: Sequence[int] | None = None,
        poly_id: int = -1,
        stippling: int = 0,
        pos_surface: int = -1,
        neg_surface: int = -1,
    ) -> None:
        self.vertices = list(vertices)
        self.vertex_ids = list(vertex_ids) if vertex_ids is not None else [-1] * len(self.vertices)
        self.sides_type = sides_type
        self.stippling = stippling
        self.pos_surface = pos_surface
        self.neg_surface = neg_surface
        self.poly_id = poly_id
        self.make_plane()

    def __repr__(self) -> str:
        return f"Polygon(id={self.poly_id}, {self.vertices!r}, plane={self.plane!r})"

    # -- construction -----------------------------------------------------
    def make_plane(self) -> None:
        """Compute the plane and the per-edge cache (CPolygon::make_plane).
        Decompiled client: FUN_00539110 (the seed, transition_pseudocode.md)."""
        verts = self.vertices
        self.num_points = n = len(verts)
        if n == 0:
            self.plane = Plane(ZERO, 0.0)
            self._nx = self._ny = self._nz = self._d = 0.0
            self._edges = ()
            return
        # in single precision for every setting: see EngineSettings.single_precision
        self.plane = plane = Plane.from_points(verts, True)
        nx, ny, nz = plane.normal.x, plane.normal.y, plane.normal.z
        self._nx, self._ny, self._nz, self._d = nx, ny, nz, plane.d
        edges: list[PolyEdge] = []
        last = verts[n - 1]
        for v in verts:
            ex, ey, ez = v.x - last.x, v.y - last.y, v.z - last.z
            # cross(normal, edge): the edge's inward normal in the plane
            kx = ny * ez - nz * ey
            ky = nz * ex - nx * ez
            kz = nx * ey - ny * ex
            edges.append(
                PolyEdge(
                    last.x,
                    last.y,
                    last.z,
                    ex,
                    ey,
                    ez,
                    kx,
                    ky,
                    kz,
                    kx * kx + ky * ky + kz * kz,
                    ex * ex + ey * ey + ez * ez,
                )
            )
            last = v
        self._edges = tuple(edges)

    # -- sphere against polygon -------------------------------------------
    def _hits_sphere_precise(self, center: Vec3, radius: float, hit: PolyHit | None) -> bool:
        """Body of polygon_hits_sphere_precise; writes hit.contact_point."""
        if self.num_points == 0:
            return True
        nx, ny, nz = self._nx, self._ny, self._nz
        cx, cy, cz = center.x, center.y, center.z
        dp_pos = nx * cx + ny * cy + nz * cz + self._d
        rad = radius - EPSILON
        if abs(dp_pos) > rad:
            return False
        diff = rad * rad - dp_pos * dp_pos
        px = cx - nx * dp_pos
        py = cy - ny * dp_pos
        pz = cz - nz * dp_pos
        if hit is not None:
            hit.contact_point = Vec3(px, py, pz)
        edges = self._edges
        for edge in edges:
            if (px - edge.lx) * edge.kx + (py - edge.ly) * edge.ky + (pz - edge.lz) * edge.kz < 0.0:
                # The projected center is outside this edge: the sphere still
                # touches the polygon if it reaches an edge segment or a vertex.
                return circle_on_edges(edges, px, py, pz, diff, False) == CIRCLE_TOUCHES
        return True

    def polygon_hits_sphere_precise(self, sphere: Sphere) -> tuple[bool, Vec3 | None]:
        """Does `sphere` (shrunk by EPSILON) touch the polygon?
        (CPolygon::polygon_hits_sphere_precise)

        Returns (hit, contact point); the contact point is the center
        projected onto the plane, None when the sphere does not reach the
        plane at all.
        """
        rec = PolyHit()
        rec.contact_point = None  # type: ignore[assignment]
        result = self._hits_sphere_precise(sphere.center, sphere.radius, rec)
        return result, rec.contact_point

    def hits_sphere(self, sphere: Sphere) -> bool:
        """CPolygon::hits_sphere: the precise sphere test, answer only."""
        return self._hits_sphere_precise(sphere.center, sphere.radius, None)

    def polygon_hits_sphere(self, sphere: Sphere) -> tuple[bool, Vec3 | None]:
        """The older, less careful sphere test (CPolygon::polygon_hits_sphere).

        Physics uses the precise variant; this one is kept for cross-checks.
        Returns (hit, contact point) like `polygon_hits_sphere_precise`.
        """
        nx, ny, nz = self._nx, self._ny, self._nz
        c = sphere.center
        dp_pos = c.x * nx + c.y * ny + c.z * nz + self._d
        rad = sphere.radius - EPSILON
        if abs(dp_pos) > rad:
            return False, None
        diff = rad * rad - dp_pos * dp_pos
        px = c.x - nx * dp_pos
        py = c.y - ny * dp_pos
        pz = c.z - nz * dp_pos
        contact = Vec3(px, py, pz)
        return circle_on_edges(self._edges, px, py, pz, diff, False) != CIRCLE_MISSES, contact

    def pos_hits_sphere(self, sphere: Sphere, movement: Vec3, hit: PolyHit | None = None) -> bool:
        """A sphere moving by `movement` runs into the polygon's front
        (CPolygon::pos_hits_sphere).

        True when the sphere touches the polygon and moves against its
        normal. When `hit` is given, the polygon is recorded in `hit.poly` on
        any touch, even if the sphere moves away and the answer is False, and
        `hit.contact_point` is updated as the precise test does.
        """
        touched = self._hits_sphere_precise(sphere.center, sphere.radius, hit)
        if touched and hit is not None:
            hit.poly = self
        if movement.x * self._nx + movement.y * self._ny + movement.z * self._nz >= 0.0:
            return False
        return touched

    # -- walkable surfaces ------------------------------------------------
    def walkable_hits_sphere(self, path: SpherePath, sphere: Sphere, up: Vec3) -> bool:
        """The polygon is steep-enough-to-stand-on for this path and the
        sphere touches it (CPolygon::walkable_hits_sphere).

        Walkable means dot(up, normal) > path.walkable_allowance.
        """
        if up.x * self._nx + up.y * self._ny + up.z * self._nz <= path.walkable_allowance:
            return False
        return self._hits_sphere_precise(sphere.center, sphere.radius, None)

    def adjust_sphere_to_plane(self, path: SpherePath, valid_pos: Sphere, movement: Vec3) -> bool:
        """Back `valid_pos` along `movement` until it rests on the plane
        (CPolygon::adjust_sphere_to_plane).

        On success moves `valid_pos.center` in place, lowers
        `path.walk_interp` to the fraction of the step still usable and
        returns True. Fails (nothing changed) when the movement runs along the
        plane, or the new interpolation would not be smaller than the current
        one or would fall below -0.5.
        """
        nx, ny, nz = self._nx, self._ny, self._nz
        c = valid_pos.center
        dp_pos = c.x * nx + c.y * ny + c.z * nz + self._d
        dp_move = movement.x * nx + movement.y * ny + movement.z * nz
        if dp_move <= EPSILON:
            if dp_move >= -EPSILON:
                return False
            dist = dp_pos - valid_pos.radius
        else:
            dist = -valid_pos.radius - dp_pos
        i_dist = dist / dp_move
        interp = (1.0 - i_dist) * path.walk_interp
        if interp >= path.walk_interp or interp < -0.5:
            return False
        valid_pos.center = Vec3(c.x - movement.x * i_dist, c.y - movement.y * i_dist, c.z - movement.z * i_dist)
        path.walk_interp = interp
        return True

    def check_walkable(self, sphere: Sphere, up: Vec3, small: bool = False) -> bool:
        """Does the sphere, dropped along `up` onto the plane, stand on the
        polygon? (CPolygon::check_walkable)

        The center is projected along `up` onto the plane; the answer is True
        if that point is inside every edge, or within the sphere's radius
        (half of it when `small`) of the first edge it lies outside of or of
        a vertex reached before. False for a plane facing away from `up`.
        """
        angle_up = self._nx * up.x + self._ny * up.y + self._nz * up.z
        if angle_up < EPSILON:
            return False
        c = sphere.center
        t = (self._nx * c.x + self._ny * c.y + self._nz * c.z + self._d) / angle_up
        radsum = sphere.radius * sphere.radius
        if small:
            radsum *= 0.25
        return circle_on_edges(self._edges, c.x - up.x * t, c.y - up.y * t, c.z - up.z * t, radsum, True) != CIRCLE_MISSES

    def check_small_walkable(self, sphere: Sphere, up: Vec3) -> bool:
        """check_walkable with a quarter of the squared radius
        (CPolygon::check_small_walkable)."""
        return self.check_walkable(sphere, up, True)

    def find_crossed_edge(self, sphere: Sphere, up: Vec3) -> Vec3 | None:
        """Normal of the first edge that the sphere's center, dropped along
        `up` onto the plane, lies outside of (CPolygon::find_crossed_edge).

        The result is the unit in-plane edge normal `cross(plane normal,
        edge)`: perpendicular to the crossed edge and pointing from it back
        into the polygon (for the counter-clockwise vertex order every
        polygon has seen from its front), i.e. against a sphere that walked
        out across that edge. Callers (PrecipiceSlide) still flip it against
        the motion. None when the center is inside every edge, or when the
        plane is (nearly) parallel to `up`.
        """
        angle_up = self._nx * up.x + self._ny * up.y + self._nz * up.z
        if abs(angle_up) < EPSILON:
            return None
        c = sphere.center
        angle = (self._nx * c.x + self._ny * c.y + self._nz * c.z + self._d) / angle_up
        px, py, pz = c.x - up.x * angle, c.y - up.y * angle, c.z - up.z * angle
        for edge in self._edges:
            if (px - edge.lx) * edge.kx + (py - edge.ly) * edge.ky + (pz - edge.lz) * edge.kz < 0.0:
                inv = 1.0 / math.sqrt(edge.kk)
                return Vec3(edge.kx * inv, edge.ky * inv, edge.kz * inv)
        return None

    # -- placement --------------------------------------------------------
    def adjust_sphere_to_poly(self, check_pos: Sphere, curr_pos: Vec3, movement: Vec3) -> float:
        """Fraction of `movement` from `curr_pos` at which a sphere of
        check_pos's radius touches the plane (CPolygon::adjust_sphere_to_poly).

        1.0 when the sphere at `curr_pos` already overlaps the plane, 0.0 when
        the movement runs along it.
        """
        nx, ny, nz = self._nx, self._ny, self._nz
        dp_pos = curr_pos.x * nx + curr_pos.y * ny + curr_pos.z * nz + self._d
        if abs(dp_pos) < check_pos.radius:
            return 1.0
        dp_move = movement.x * nx + movement.y * ny + movement.z * nz
        if abs(dp_move) < EPSILON:
            return 0.0
        dist = check_pos.radius
        if movement.length_sq() <= dist * dist:
            dist = -dist
        return (dist - dp_pos) / dp_move

    def adjust_to_placement_poly(
        self,
        hit_sphere: Sphere,
        other_sphere: Sphere | None,
        radius: float,
        center_solid: bool,
        solid_check: bool,
    ) -> None:
        """Push `hit_sphere` (and `other_sphere` with it) along the normal so
        its center ends `radius` in front of the plane, or `radius` behind it
        when solids are checked and the center is in solid or behind the
        plane (CPolygon::adjust_to_placement_poly). Moves the spheres in place.
        """
        nx, ny, nz = self._nx, self._ny, self._nz
        c = hit_sphere.center
        dp = c.x * nx + c.y * ny + c.z * nz + self._d
        if solid_check and (center_solid or dp <= 0.0):
            radius = -radius
        diff = radius - dp
        adjusted = Vec3(nx * diff, ny * diff, nz * diff)
        hit_sphere.center = c + adjusted
        if other_sphere is not None:
            other_sphere.center = other_sphere.center + adjusted

    # -- points and rays --------------------------------------------------
    def point_in_polygon(self, point: Vec3) -> bool:
        """`point` (on the plane) is inside or on every edge
        (CPolygon::point_in_polygon)."""
        px, py, pz = point.x, point.y, point.z
        for edge in self._edges:
            if edge.kx * (px - edge.lx) + edge.ky * (py - edge.ly) + edge.kz * (pz - edge.lz) < 0.0:
                return False
        return True

    def point_in_poly_2d(self, point: Vec3, side: int) -> bool:
        """2-D (x, y) inside test, walking the vertex loop backwards
        (CPolygon::point_in_poly2D). `side` is a Side / Sidedness value:
        FRONT (0, Positive) for a loop that is counter-clockwise seen from +z
        (terrain triangles), anything else for a clockwise one. Points on an
        edge count as inside.
        """
        verts = self.vertices
        prev = verts[0]
        for i in range(self.num_points - 1, -1, -1):
            v = verts[i]
            dx = v.x - prev.x
            dy = v.y - prev.y
            cross = dy * v.x - dx * v.y + dx * point.y - dy * point.x
            if side != 0:
                if cross < 0.0:
                    return False
            elif cross > 0.0:
                return False
            prev = v
        return True

    def polygon_hits_ray(self, ray: Ray) -> float | None:
        """Time along `ray` at which it meets the polygon, or None
        (CPolygon::polygon_hits_ray). A single-sided (LANDBLOCK) polygon is
        not hit from behind; a ray parallel to the plane or pointing away
        from it misses.
        Decompiled client: FUN_00539060 (the seed, transition_pseudocode.md)."""
        nx, ny, nz = self._nx, self._ny, self._nz
        d = ray.dir
        angle = d.x * nx + d.y * ny + d.z * nz
        if self.sides_type == CullMode.LANDBLOCK and angle > 0.0:
            return None
        # Plane.compute_time_of_intersection
        if abs(angle) < EPSILON:
            return None
        p = ray.point
        time = (p.x * nx + p.y * ny + p.z * nz + self._d) * (-1.0 / angle)
        if not time >= 0.0:
            return None
        if not self.point_in_polygon(Vec3(p.x + d.x * time, p.y + d.y * time, p.z + d.z * time)):
            return None
        return time

