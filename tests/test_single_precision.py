"""Computations the engine does in single precision, as the client does.

Expected values come from numpy.float32 arithmetic written out in the order
of the client's C# expressions, and from the reference traces (whose
numbers are the client's float32 values).
"""

from __future__ import annotations

import random

import numpy as np
import pytest

import engine
from engine.geometry import Frame, Plane, Position, Sphere, Vec3
from engine.geometry.precision import fl_cross, fl_dot, fl_plane_dist
from engine.settings import ACE_COMPAT
from engine.transition.sphere_path import SpherePath
from engine.transition.transition import Transition
from support.shared_data import load_trace, needs_shared, scene_path

F = np.float32


def _rand_f32(rng: random.Random, scale: float) -> float:
    return float(F(rng.uniform(-scale, scale)))


def test_dot_and_plane_distance_round_every_operation() -> None:
    rng = random.Random(7)
    for _ in range(2000):
        a = [_rand_f32(rng, 200.0) for _ in range(3)]
        b = [_rand_f32(rng, 1.0) for _ in range(3)]
        d = _rand_f32(rng, 150.0)
        fa = [F(x) for x in a]
        fb = [F(x) for x in b]
        expected = (fa[0] * fb[0] + fa[1] * fb[1]) + fa[2] * fb[2]
        assert fl_dot(*a, *b, True) == float(expected)
        assert fl_plane_dist(a[0], a[1], a[2], Plane(Vec3(*b), d), True) == float(expected + F(d))
        cx = fa[1] * fb[2] - fa[2] * fb[1]
        cy = fa[2] * fb[0] - fa[0] * fb[2]
        cz = fa[0] * fb[1] - fa[1] * fb[0]
        c = fl_cross(Vec3(*a), Vec3(*b), True)
        assert (c.x, c.y, c.z) == (float(cx), float(cy), float(cz))


@needs_shared
@pytest.mark.parametrize("trace", ["steep", "cliff", "rolling"])
def test_terrain_planes_are_the_reference_contact_planes(trace: str) -> None:
    """Every terrain contact plane the reference reports is, bit for bit, the
    plane of one of the two triangles of its cell (the client builds them in
    float32: Polygon.make_plane on the landblock's vertices)."""
    data = load_trace(trace)
    world = engine.load_scene(scene_path(data["scene"]))
    seen = set()
    for case in data["cases"]:
        for move in case.get("moves", []):
            e = move["expect"]
            cp, cell = e.get("contact_plane"), e.get("contact_plane_cell")
            if not cp or not cell or (int(cell, 16) & 0xFFFF) >= 0x100:
                continue
            key = (cell, tuple(cp["normal"]), cp["d"])
            if key in seen:
                continue
            seen.add(key)
            want = ([float(F(x)) for x in cp["normal"]], float(F(cp["d"])))
            tris = world.get_landcell(int(cell, 16)).polygons
            got = [([t.plane.normal.x, t.plane.normal.y, t.plane.normal.z], t.plane.d) for t in tris]
            assert want in got, (cell, want, got)
    assert len(seen) > 50


def test_adjust_offset_lifts_onto_the_contact_plane_in_float32() -> None:
    """AdjustOffset puts a sphere sunk into its contact plane back on it; the
    lift is (r - dist) / n.z with dist = dot(center, n) + d, all in float32."""
    r = 0.5
    center = (116.38134, 44.4162254, 113.96586)
    n = (-0.296811551, -0.09893719, 0.949797034)
    d = -68.86029
    # float32 by hand, in the client's order
    fc = [F(x) for x in center]
    fn = [F(x) for x in n]
    dist = ((fc[0] * fn[0] + fc[1] * fn[1]) + fc[2] * fn[2]) + F(d)
    expected_z = fc[2] + (F(r) - dist) / fn[2]
    assert float(expected_z) == float(F(114.022285))
    # float64 arithmetic lands one float32 step higher here
    d64 = sum(float(a) * float(b) for a, b in zip(fc, fn)) + float(F(d))
    assert float(F(float(fc[2]) + (r - d64) / float(fn[2]))) != float(expected_z)

    cell = 0xA9B40022
    path = SpherePath()
    path.init_sphere([Sphere(Vec3(0.0, 0.0, r), r)], 1.0)
    pos = Position(cell, Frame(Vec3(float(fc[0]), float(fc[1]), float(fc[2]) - r)))
    path.init_path(None, pos, pos)
    path.set_check_pos(pos, None)
    assert path.global_sphere[0].center.z == float(fc[2])
    t = Transition(None, ACE_COMPAT)
    t.sphere_path = path
    plane = Plane(Vec3(*(float(x) for x in fn)), float(F(d)))
    t.init_contact_plane(cell, plane, False)
    offset = t.adjust_offset(Vec3(0.0, 0.0, 0.0))
    assert offset == Vec3(0.0, 0.0, 0.0)
    assert path.global_sphere[0].center.z == float(expected_z)


# -- rotations and placements in float32 ----------------------------------------------


def _np_transform_quat(q: tuple[float, float, float, float], v: tuple[float, float, float]) -> tuple[float, ...]:
    """System.Numerics Vector3.Transform(v, q), written out in numpy float32."""
    w, x, y, z = (F(c) for c in q)
    vx, vy, vz = (F(c) for c in v)
    x2, y2, z2 = x + x, y + y, z + z
    wx2, wy2, wz2 = w * x2, w * y2, w * z2
    xx2, xy2, xz2 = x * x2, x * y2, x * z2
    yy2, yz2, zz2 = y * y2, y * z2, z * z2
    one = F(1.0)
    return (
        float(vx * (one - yy2 - zz2) + vy * (xy2 - wz2) + vz * (xz2 + wy2)),
        float(vx * (xy2 + wz2) + vy * (one - xx2 - zz2) + vz * (yz2 - wx2)),
        float(vx * (xz2 - wy2) + vy * (yz2 + wx2) + vz * (one - xx2 - yy2)),
    )


def _np_inverse_transform(q: tuple[float, float, float, float], v: tuple[float, float, float]) -> tuple[float, ...]:
    """Vector3.Transform(v, Matrix4x4.Transpose(Matrix4x4.CreateFromQuaternion(q))) in numpy float32."""
    w, x, y, z = (F(c) for c in q)
    vx, vy, vz = (F(c) for c in v)
    xx, yy, zz = x * x, y * y, z * z
    xy, wz, xz, wy, yz, wx = x * y, z * w, z * x, y * w, y * z, x * w
    one, two = F(1.0), F(2.0)
    m11, m12, m13 = one - two * (yy + zz), two * (xy + wz), two * (xz - wy)
    m21, m22, m23 = two * (xy - wz), one - two * (zz + xx), two * (yz + wx)
    m31, m32, m33 = two * (xz + wy), two * (yz - wx), one - two * (yy + xx)
    # the transpose's row i is column i of M
    return (
        float(vx * m11 + vy * m12 + vz * m13),
        float(vx * m21 + vy * m22 + vz * m23),
        float(vx * m31 + vy * m32 + vz * m33),
    )


def test_rotations_round_as_system_numerics_does() -> None:
    from engine.geometry import Quat
    from engine.geometry.precision import fl_local_z, fl_rotate, fl_unrotate

    rng = random.Random(7)
    for _ in range(300):
        angle = rng.uniform(-3.2, 3.2)
        axis = Vec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)).normalized_or_none()
        assert axis is not None
        s = np.sin(angle / 2)
        q = (float(F(np.cos(angle / 2))), float(F(axis.x * s)), float(F(axis.y * s)), float(F(axis.z * s)))
        v = (_rand_f32(rng, 200.0), _rand_f32(rng, 200.0), _rand_f32(rng, 5.0))
        quat = Quat(*q)
        assert fl_rotate(quat, Vec3(*v), True).as_tuple() == _np_transform_quat(q, v)
        assert fl_unrotate(quat, Vec3(*v), True).as_tuple() == _np_inverse_transform(q, v)
        assert fl_local_z(quat, True).as_tuple() == _np_inverse_transform(q, (0.0, 0.0, 1.0))
    # the identity leaves a vector as it is, bit for bit
    v0 = Vec3(0.1, -2.5, 1e-3)
    assert fl_rotate(Quat(), v0, True) is v0 and fl_unrotate(Quat(), v0, True) is v0


def test_an_obstacle_sphere_is_placed_in_float32() -> None:
    from engine.geometry import Quat
    from engine.geometry.precision import fl_place

    # a quarter turn about z at (100.3, 50.7, 20.1), scale 1.5, a point (0.48, 0.1, 1.35)
    # of the object: (x, y, z) -> (-y, x, z), times 1.5, plus the origin; all float32
    s = float(F(np.sqrt(0.5)))
    q = (s, 0.0, 0.0, s)
    origin = tuple(float(F(c)) for c in (100.3, 50.7, 20.1))
    point = (0.48, 0.1, 1.35)
    pos = Position(0xA9B40101, Frame(Vec3(*origin), Quat(*q)))
    scaled = tuple(float(F(c) * F(1.5)) for c in point)
    r = _np_transform_quat(q, scaled)  # type: ignore[arg-type]
    expected = tuple(float(F(o) + F(c)) for o, c in zip(origin, r))
    assert fl_place(0xA9B40101, pos, Vec3(*point), 1.5, True).as_tuple() == expected
    assert fl_place(0xA9B40101, pos, Vec3(*point), 1.5, True).as_tuple() == pytest.approx((100.3 - 0.15, 50.7 + 0.72, 20.1 + 2.025), abs=1e-5)
    # from the next landblock east: 192 m further along x
    east = fl_place(0xAAB40001, pos, Vec3(*point), 1.5, True)
    assert east.as_tuple() == (float(F(-192.0) + F(expected[0])), expected[1], expected[2])
