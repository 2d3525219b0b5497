"""Property tests: random walks over random terrain stay finite and on the ground."""

from __future__ import annotations

import math

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from engine import Plane, Position, Vec3
from benchmarks.scenes import PLAYER, world_from_heights

LB = 0xA9B40000

heights_strategy = st.lists(st.integers(min_value=60, max_value=140), min_size=81, max_size=81)
walk_strategy = st.lists(
    st.tuples(st.floats(min_value=0.0, max_value=2 * math.pi), st.floats(min_value=0.0, max_value=0.9)),
    min_size=20,
    max_size=60,
)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(heights=heights_strategy, walk=walk_strategy)
def test_random_walks_never_go_nan_or_under_the_ground(heights: list[int], walk: list[tuple[float, float]]) -> None:
    world = world_from_heights(lambda bx, by, x, y: heights[x * 9 + y])
    terrain = world.landblocks[0xA9B4].terrain
    x0, y0 = 96.0, 96.0
    z0 = terrain.height_at(x0, y0)
    n = terrain.normal_at(x0, y0)
    cell = LB | (4 * 8 + 4 + 1)
    mid = world.add_mover(PLAYER, Position.at(cell, Vec3(x0, y0, z0)), Plane(n, -n.dot(Vec3(x0, y0, z0))), cell)
    for heading, length in walk:
        m = world.mover(mid)
        o = m.position.origin
        step = Vec3(math.sin(heading) * length, math.cos(heading) * length, 0.0)
        target = m.position.with_origin(o + step)
        # stay on this landblock: the world holds only one
        if not (2.0 < target.origin.x < 190.0 and 2.0 < target.origin.y < 190.0):
            continue
        r = world.move(mid, target)
        p = r.position.origin
        assert p.is_finite(), f"non-finite position {p}"
        assert r.position.cell_id >> 16 == 0xA9B4
        if r.contact:
            ground = terrain.height_at(p.x, p.y)
            # the foot sphere's lowest point (the origin) never sinks below the surface under it
            assert p.z > ground - 0.01, f"{p.z} is {ground - p.z:.3f} m below the terrain"
