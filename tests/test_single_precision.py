"""Computations the engine does in single precision, as the client does.

Expected values come from numpy.float32 arithmetic written out in the order
of the client's C# expressions, and from the reference traces (whose
numbers are the client's float32 values).
"""

from __future__ import annotations

import gzip
import json
import random
from pathlib import Path

import numpy as np
import pytest

import engine
from engine.geometry import Frame, Plane, Position, Sphere, Vec3
from engine.geometry.f32 import cross_f32, dot_f32, f32, plane_dist_f32
from engine.transition.settings import ACE_COMPAT
from engine.transition.sphere_path import SpherePath
from engine.transition.transition import Transition

F = np.float32
ORACLE = Path(__file__).resolve().parent.parent.parent / "shared" / "oracle"


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
        assert dot_f32(*a, *b) == float(expected)
        assert plane_dist_f32(a[0], a[1], a[2], Plane(Vec3(*b), d)) == float(expected + F(d))
        cx = fa[1] * fb[2] - fa[2] * fb[1]
        cy = fa[2] * fb[0] - fa[0] * fb[2]
        cz = fa[0] * fb[1] - fa[1] * fb[0]
        c = cross_f32(Vec3(*a), Vec3(*b))
        assert (c.x, c.y, c.z) == (float(cx), float(cy), float(cz))


@pytest.mark.parametrize("trace", ["steep", "cliff", "rolling"])
def test_terrain_planes_are_the_reference_contact_planes(trace: str) -> None:
    """Every terrain contact plane the reference reports is, bit for bit, the
    plane of one of the two triangles of its cell (the client builds them in
    float32: Polygon.make_plane on the landblock's vertices)."""
    with gzip.open(ORACLE / "traces" / f"{trace}.trace.json.gz", "rt") as f:
        data = json.load(f)
    world = engine.load_scene(ORACLE / "scenes" / data["scene"])
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
