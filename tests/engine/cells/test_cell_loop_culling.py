"""The cell loop's broad phase (ObjCell.find_obj_collisions with `skip_far_movers`, engine.cells.broad_phase)
on a randomized crowd: it hands the narrow phase the same movers, in the same order (newest first, the
client's CObjCell::find_obj_collisions order), as the plain scan does, leaving out only movers none of
the path's spheres touches; and a mover's box, placed again in place as it walks and turns, holds its
spheres where a hand computation puts them.

The overlaps are computed here from the movers' specs, positions and headings (yaw-only rotations,
worked out with cos and sin), not with the engine's boxes.
"""

from __future__ import annotations

import dataclasses
import math
import random
from typing import Any

import pytest

import engine
import engine.cells.obj_cell
from engine import MoverSpec, Position, Quat, SphereSpec, Vec3
from engine.cells.broad_phase import MARGIN, mover_bounds
from engine.geometry import Frame
from engine.objects.obstacle import MoverObstacle
from engine.transition.state import TransitionState
from engine.world import shadows

LB = 0xA9B40000
GROUND = 50.0
OFF = dataclasses.replace(engine.RETAIL, skip_far_movers=False)
pytestmark = pytest.mark.skipif(not engine.cells.obj_cell.__file__.endswith(".py"),
                                reason="records the narrow-phase calls by patching a class (interpreted engine only)")


def _world(settings: engine.EngineSettings) -> engine.World:
    """Landblock A9B4 flat at 50 m (height index 100 of a table of half metres)."""
    return engine.world_from_scene_dict({
        "format": "acphys-scene/1", "name": "culling", "height_table": [i * 0.5 for i in range(256)],
        "landblocks": [{"id": "A9B4", "heights": [100] * 81}],
    }, settings=settings)


def _cell(x: float, y: float) -> int:
    return LB | (int(x // 24) * 8 + int(y // 24) + 1)


def _yaw(angle: float) -> Quat:
    return Quat(math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2))


def _spec(rng: random.Random) -> MoverSpec:
    """A creature of one or two spheres, some off its axis (so that its heading moves them)."""
    foot = SphereSpec((rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), 0.5), rng.uniform(0.3, 0.5))
    spheres = [foot]
    if rng.random() < 0.7:
        spheres.append(SphereSpec((rng.uniform(-0.4, 0.4), 0.0, 1.3), rng.uniform(0.25, 0.5)))
    return MoverSpec(spheres=spheres, state=["Contact", "OnWalkable"], creature=True,
                     step_up_height=0.4, step_down_height=0.4)


@dataclasses.dataclass
class _Crowd:
    """A crowd's layout and moves, drawn once from a seed (the same for both runs)."""

    specs: list[MoverSpec]
    starts: list[tuple[float, float, float]]
    moves: list[tuple[int, float, float, float]]  # (which, dx, dy, new heading)


def _draw(seed: int, count: int = 60, moves: int = 400) -> _Crowd:
    rng = random.Random(seed)
    # a 14 m square across the corner of four cells (x, y = 72 and 96 are cell edges at 24 m)
    starts = [(rng.uniform(65.0, 79.0), rng.uniform(89.0, 103.0), rng.uniform(-math.pi, math.pi)) for _ in range(count)]
    steps = [(rng.randrange(count), rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6), rng.uniform(-math.pi, math.pi))
             for _ in range(moves)]
    return _Crowd([_spec(rng) for _ in range(count)], starts, steps)


def _run(crowd: _Crowd, settings: engine.EngineSettings, monkeypatch: pytest.MonkeyPatch
         ) -> tuple[list[Any], list[list[tuple[int, bool, bool]]], engine.World, list[int]]:
    """Every move's answer, and for every move the narrow-phase tests it ran:
    (the tested mover's id, did the path's spheres overlap its spheres before the test (computed here),
    did it answer OK)."""
    world = _world(settings)
    ids: list[int] = []
    specs: dict[int, list[SphereSpec]] = {}
    for spec, (x, y, heading) in zip(crowd.specs, crowd.starts):
        try:
            mid = world.add_mover(spec, Position(_cell(x, y), Frame(Vec3(x, y, GROUND), _yaw(heading))),
                                  placement="enter_world")
        except engine.EngineError:
            continue  # no room there
        ids.append(mid)
        specs[mid] = list(spec.spheres)
    tested: list[list[tuple[int, bool, bool]]] = []
    original = MoverObstacle.find_obj_collisions

    def recording(self: MoverObstacle, transition: Any) -> int:
        if self.mover is transition.object_info.obj:
            return int(original(self, transition))  # the path's own shadow (the loop passes over it when culling)
        path = transition.sphere_path
        mid = self.mover.id
        frame = self.mover.position.frame
        origin, q = frame.origin, frame.orientation  # (a yaw: w = cos(yaw / 2), z = sin(yaw / 2))
        yaw = 2.0 * math.atan2(q.z, q.w)
        c, s = math.cos(yaw), math.sin(yaw)
        touch = False
        foot = path.global_sphere[0].radius
        for k in range(min(path.num_sphere, 2)):
            p = path.global_sphere[k]
            reach = max(p.radius, foot)  # the tests measure the head with the foot's radius
            for sphere in specs[mid]:
                (x, y, z), r = sphere.center, sphere.radius
                centre = (origin.x + c * x - s * y, origin.y + s * x + c * y, origin.z + z)
                # overlapping by a millimetre at least (a graze may be passed over or not)
                if math.dist(centre, p.center.as_tuple()) < reach + r - 0.001:
                    touch = True
        state = int(original(self, transition))  # (after: the test may move the path's spheres)
        tested[-1].append((mid, touch, state == TransitionState.OK))
        return state

    monkeypatch.setattr(MoverObstacle, "find_obj_collisions", recording)
    answers: list[Any] = []
    for which, dx, dy, heading in crowd.moves:
        if which >= len(ids):
            continue
        mid = ids[which]
        p = world.mover(mid).position
        o = p.frame.origin
        target = Position(p.cell_id, Frame(Vec3(o.x + dx, o.y + dy, o.z), _yaw(heading)))
        tested.append([])
        r = world.move(mid, target)
        answers.append((r.ok, r.transition_state, r.position.cell_id, r.position.frame.origin.as_tuple(),
                        tuple(r.collide_objects)))
    monkeypatch.undo()
    return answers, tested, world, ids


def _within(part: list[Any], whole: list[Any]) -> bool:
    """Is `part` `whole` with some entries taken out (a subsequence)?"""
    it = iter(whole)
    return all(any(t == u for u in it) for t in part)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_loop_tests_the_plain_scans_movers_in_its_order_leaving_out_only_untouched_ones(
        seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    crowd = _draw(seed)
    on_answers, on_tested, _, _ = _run(crowd, engine.RETAIL, monkeypatch)
    off_answers, off_tested, _, _ = _run(crowd, OFF, monkeypatch)
    assert on_answers == off_answers
    assert any(a[4] for a in on_answers)  # the crowd bumped: real collisions were compared
    left_out = 0
    for move, (on, off) in enumerate(zip(on_tested, off_tested, strict=True)):
        # what the loop tested is the plain scan's tests with some taken out, in the same order ...
        assert _within(on, off), f"move {move}: {on} is not the plain scan's {off} in order"
        # ... and every one the path touched, or that answered anything but OK, is still there
        assert _within([t for t in off if t[1] or not t[2]], on), f"move {move}: {on} lacks one of {off}"
        left_out += len(off) - len(on)
    assert left_out > sum(len(off) for off in off_tested) // 2  # the broad phase passed over most of them


def test_a_walking_and_turning_movers_box_holds_its_spheres() -> None:
    world = _world(engine.RETAIL)
    spec = MoverSpec(spheres=[SphereSpec((0.5, 0.2, 0.4), 0.4), SphereSpec((-0.3, 0.0, 1.2), 0.3)],
                     state=["Contact", "OnWalkable"], scale=1.5)
    heading = 0.3
    mid = world.add_mover(spec, Position(_cell(60.0, 60.0), Frame(Vec3(60.0, 60.0, GROUND), _yaw(heading))))
    obstacle = shadows.obstacle_of(world.mover(mid))
    rng = random.Random(7)
    for step in range(40):
        if step % 5 == 4:
            heading = rng.uniform(-math.pi, math.pi)  # a turn: a new orientation
        p = world.mover(mid).position
        o = p.frame.origin
        world.move(mid, Position(p.cell_id, Frame(Vec3(o.x + rng.uniform(-0.5, 0.5), o.y + rng.uniform(-0.5, 0.5), o.z),
                                                   p.frame.orientation if step % 5 != 4 else _yaw(heading))))
        o = world.mover(mid).position.frame.origin
        c, s = math.cos(heading), math.sin(heading)
        # each sphere's centre turned by the heading, scaled by 1.5, and its radius scaled: the box's extent
        xs = [(o.x + 1.5 * (c * x - s * y), 1.5 * r) for (x, y, _), r in ((q.center, q.radius) for q in spec.spheres)]
        ys = [(o.y + 1.5 * (s * x + c * y), 1.5 * r) for (x, y, _), r in ((q.center, q.radius) for q in spec.spheres)]
        zs = [(o.z + 1.5 * z, 1.5 * r) for (_, _, z), r in ((q.center, q.radius) for q in spec.spheres)]
        box = mover_bounds(obstacle)  # type: ignore[arg-type]
        got = (box.min_x, box.max_x, box.min_y, box.max_y, box.min_z, box.max_z)
        want = (min(v - r for v, r in xs) - MARGIN, max(v + r for v, r in xs) + MARGIN,
                min(v - r for v, r in ys) - MARGIN, max(v + r for v, r in ys) + MARGIN,
                min(v - r for v, r in zs) - MARGIN, max(v + r for v, r in zs) + MARGIN)
        assert got == pytest.approx(want, abs=1e-5), step
        assert box.block == LB >> 16


def test_a_walk_within_its_cell_makes_the_walker_the_cells_newest_shadow() -> None:
    # three movers in the middle of one cell (x, y 48..72), far from its edges: each shadows that cell
    # alone. The client removes a mover's shadows after each move and adds them again, newest last
    # (SetPositionInternal), so after walks by a, b, c, a the list holds b, c, a (oldest first).
    world = _world(engine.RETAIL)
    spec = MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.5), 0.5)], state=["Contact", "OnWalkable"])
    a, b, c = (world.add_mover(spec, Position.at(_cell(x, 60.0), Vec3(x, 60.0, GROUND))) for x in (54.0, 60.0, 66.0))
    cell = world.mover(a).cell
    assert cell is not None and cell.shadow_objects == [shadows.obstacle_of(world.mover(m)) for m in (a, b, c)]
    for mid in (a, b, c, a):
        o = world.mover(mid).position.frame.origin
        assert world.move(mid, Position.at(_cell(o.x, o.y + 0.3), Vec3(o.x, o.y + 0.3, o.z))).ok
    assert [world.mover(m).shadow_cells for m in (a, b, c)] == [[cell]] * 3
    assert cell.shadow_objects == [shadows.obstacle_of(world.mover(m)) for m in (b, c, a)]
