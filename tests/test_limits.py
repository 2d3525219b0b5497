"""Limits at the door: what a caller gives the World is checked before anything changes.

Each hostile input below is refused with an EngineError naming its
field; the mover it names stays exactly as it was (position, contact,
velocity), and a neighbour's moves give bit-identical results to a run in
which the hostile calls were never made.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import pytest

import engine
from engine import MoverSpec, OutOfRangeError, Plane, Position, SphereSpec, Vec3
from engine.constants import MAX_VELOCITY
from engine.errors import EngineError, NonFiniteError
from benchmarks.scenes import PLAYER
from engine.limits import FLOAT32_MAX, MAX_OBJECT_SIZE, TARGET_MARGIN

HEIGHTS = [b * 0.5 for b in range(256)]
LB = 0xA9B40000


def flat_world() -> engine.World:
    """Three by three landblocks of flat ground at 50 m (height byte 100)."""
    blocks = [(0xA9 + dx, 0xB4 + dy) for dx in (-1, 0, 1) for dy in (-1, 0, 1)]
    return engine.world_from_scene_dict({
        "format": "acphys-scene/1", "name": "limits", "height_table": HEIGHTS,
        "landblocks": [{"id": f"{bx:02X}{by:02X}", "heights": [100] * 81} for bx, by in blocks],
    })


GROUND = Plane(Vec3(0.0, 0.0, 1.0), -50.0)


def cell(x: float, y: float) -> int:
    return LB | (int(x // 24) * 8 + int(y // 24) + 1)


def stand(world: engine.World, x: float, y: float, spec: MoverSpec = PLAYER) -> int:
    return world.add_mover(spec, Position.at(cell(x, y), Vec3(x, y, 50.0)), GROUND, cell(x, y))


def snapshot(world: engine.World, mid: int) -> tuple[Any, ...]:
    """Everything a move may change on a mover, exactly."""
    m = world.mover(mid)
    return (repr(world.mover_state(mid)), m.velocity.as_tuple(), m.transient, repr(m.contact_plane), m.missile)


#: the neighbour's moves: a walk that passes close to where the hostile movers stand
NEIGHBOUR_WALK = [Vec3(0.4, 0.0, 0.0)] * 6 + [Vec3(0.0, 0.4, 0.0)] * 6 + [Vec3(-0.3, -0.3, 0.0)] * 4


def neighbour_run(hostile: Callable[[engine.World, int], None] | None) -> list[str]:
    """The neighbour's results, with `hostile` called (on a mover of its own) before each of its moves."""
    world = flat_world()
    neighbour = stand(world, 60.0, 60.0)
    victim = stand(world, 63.0, 61.0)  # the mover the hostile calls name
    out = []
    for off in NEIGHBOUR_WALK:
        if hostile is not None:
            before = snapshot(world, victim)
            with pytest.raises(EngineError) as err:
                hostile(world, victim)
            assert err.value.field, "the error names the field"
            assert snapshot(world, victim) == before, "a refused call changed its mover"
        out.append(repr(world.move(neighbour, world.mover(neighbour).position.moved(off))))
    out.append(repr(world.mover_state(victim)))  # the victim, too, is where it started
    return out


def _move_by(off: Vec3) -> Callable[[engine.World, int], None]:
    return lambda w, m: w.move(m, w.mover(m).position.moved(off))


def _register(spec: MoverSpec | None = None, origin: Vec3 | None = None, cell_id: int | None = None) -> Callable[[engine.World, int], None]:
    def call(w: engine.World, _m: int) -> None:
        o = origin if origin is not None else Vec3(61.0, 64.0, 50.0)
        w.add_mover(spec if spec is not None else PLAYER, Position.at(cell_id if cell_id is not None else cell(61.0, 64.0), o))
    return call


def _sphere(radius: float, **kw: Any) -> MoverSpec:
    return MoverSpec(spheres=[SphereSpec((0.0, 0.0, min(radius, 1.0)), radius)], **kw)


HOSTILE: dict[str, tuple[Callable[[engine.World, int], None], type[EngineError], str]] = {
    "offset 1e200": (_move_by(Vec3(1e200, 0.0, 0.0)), OutOfRangeError, "target.origin[0]"),
    "offset 1e300 up": (_move_by(Vec3(0.0, 0.0, 1e300)), OutOfRangeError, "target.origin[2]"),
    "target 1e30 in y": (lambda w, m: w.move(m, Position.at(cell(63.0, 61.0), Vec3(63.0, 1e30, 50.0))), OutOfRangeError,
                         "target.origin[1]"),
    "target two landblocks off": (_move_by(Vec3(0.0, 3.0 * TARGET_MARGIN, 0.0)), OutOfRangeError, "target.origin[1]"),
    "target NaN": (_move_by(Vec3(math.nan, 0.0, 0.0)), NonFiniteError, "target.origin[0]"),
    "velocity 1e30": (lambda w, m: w.move(m, w.mover(m).position.moved(Vec3(0.3, 0.0, 0.0)), Vec3(1e30, 0.0, 0.0)),
                      OutOfRangeError, "velocity"),
    "velocity beyond float32": (lambda w, m: w.move(m, w.mover(m).position, Vec3(0.0, 1e39, 0.0)), OutOfRangeError,
                                "velocity[1]"),
    "zero orientation": (lambda w, m: w.move(m, Position.at(cell(63.0, 61.0), Vec3(63.0, 61.0, 50.0), engine.Quat(0.0, 0.0, 0.0, 0.0))),
                         OutOfRangeError, "target.orientation"),
    "motion 1e30": (lambda w, m: w.step(m, Vec3(1e30, 0.0, 0.0), 1.0 / 30.0), OutOfRangeError, "motion[0]"),
    "negative dt": (lambda w, m: w.step(m, Vec3(0.0, 0.0, 0.0), -1.0), OutOfRangeError, "dt"),
    "dt 1e39": (lambda w, m: w.step(m, Vec3(0.0, 0.0, 0.0), 1e39), OutOfRangeError, "dt"),
    "dt 1e30": (lambda w, m: w.step(m, Vec3(0.0, 0.0, 0.0), 1e30), OutOfRangeError, "dt"),  # squared: beyond float32
    "giant sphere 1e39": (_register(_sphere(1e39)), OutOfRangeError, "spec.spheres[0].radius"),
    "giant sphere 1e30": (_register(_sphere(1e30)), OutOfRangeError, "spec.spheres[0].radius"),
    "sphere bigger than a landblock": (_register(_sphere(MAX_OBJECT_SIZE * 1.01)), OutOfRangeError, "spec.spheres[0].radius"),
    "sphere made giant by scale": (_register(_sphere(10.0, scale=100.0)), OutOfRangeError, "spec.spheres[0].radius"),
    # under a millimetre a sphere is lost in the transition's 0.2 mm tolerance (engine.limits.MIN_SPHERE_RADIUS)
    "sphere of half a millimetre": (_register(_sphere(5e-4)), OutOfRangeError, "spec.spheres[0].radius"),
    "sphere made tiny by scale": (_register(_sphere(0.1, scale=0.005)), OutOfRangeError, "spec.spheres[0].radius"),
    "scale 1e30": (_register(_sphere(0.5, scale=1e30)), OutOfRangeError, "spec.scale"),
    "step height 1e30": (_register(_sphere(0.5, step_up_height=1e30)), OutOfRangeError, "spec.step_up_height"),
    "step-down height 1e30": (_register(_sphere(0.5, step_down_height=1e30)), OutOfRangeError, "spec.step_down_height"),
    "origin at 1e30": (_register(origin=Vec3(1e30, 64.0, 50.0)), OutOfRangeError, "position.origin[0]"),
    "origin outside the cell's landblock": (_register(origin=Vec3(200.0, 64.0, 50.0)), OutOfRangeError, "position.origin[0]"),
    "origin 1e30 underground": (_register(origin=Vec3(61.0, 64.0, -1e30)), OutOfRangeError, "position.origin[2]"),
    "update to a giant": (lambda w, m: w.update_mover(m, _sphere(1e30)), OutOfRangeError, "spec.spheres[0].radius"),
    "contact plane far off": (lambda w, m: w.add_mover(PLAYER, Position.at(cell(61.0, 64.0), Vec3(61.0, 64.0, 50.0)),
                                                       Plane(Vec3(0.0, 0.0, 1.0), 1e30)), OutOfRangeError, "contact_plane.d"),
    "sliding normal 1e30 long": (lambda w, m: w.add_mover(PLAYER, Position.at(cell(61.0, 64.0), Vec3(61.0, 64.0, 50.0)),
                                                          sliding_normal=Vec3(1e30, 0.0, 0.0)), OutOfRangeError, "sliding_normal"),
}


@pytest.fixture(scope="module")
def undisturbed() -> list[str]:
    return neighbour_run(None)


@pytest.mark.parametrize("name", list(HOSTILE))
def test_a_hostile_input_is_refused_and_changes_nothing_for_anyone(name: str, undisturbed: list[str]) -> None:
    call, error, field = HOSTILE[name]
    world = flat_world()
    victim = stand(world, 63.0, 61.0)
    with pytest.raises(error) as err:
        call(world, victim)
    assert err.value.field is not None and err.value.field.startswith(field), err.value.field
    assert len(world.movers) == 1  # a refused registration registered nothing
    assert neighbour_run(call) == undisturbed  # bit-identical, every move of the neighbour


def test_the_limits_are_what_the_client_can_hold() -> None:
    assert FLOAT32_MAX == float.fromhex("0x1.fffffep+127")  # the largest finite float32
    assert MAX_OBJECT_SIZE == 192.0  # a landblock
    world = flat_world()
    # the largest allowed sphere and a target at the margin are accepted and answered
    giant = world.add_mover(_sphere(MAX_OBJECT_SIZE, step_up_height=0.4), Position.at(cell(96.0, 96.0), Vec3(96.0, 96.0, 250.0)))
    r = world.move(giant, world.mover(giant).position.moved(Vec3(1.0, 0.0, 0.0)))
    assert all(math.isfinite(c) for c in r.position.origin.as_tuple())
    mid = stand(world, 100.0, 100.0)
    r = world.move(mid, Position.at(cell(100.0, 100.0), Vec3(100.0, 100.0 + 0.5, 50.0)))
    assert r.ok


class _FailingLookups(dict[int, Any]):
    """Landblocks whose `fail_at`-th lookup raises. The engine reaches a dict subclass of landblocks
    (the dat world's LRU is one) through its own methods, so this fails a move at any point, from the
    checks at the door to the last cell lookup of the transition, in pure and compiled builds alike."""

    def __init__(self, blocks: dict[int, Any], fail_at: int) -> None:
        super().__init__(blocks)
        self.lookups = 0
        self.fail_at = fail_at
        #: the method whose lookup raised: `contains` is the landblock check at the door, `get` a cell
        #: lookup inside the transition
        self.failed_in = ""

    def _count(self, method: str) -> None:
        self.lookups += 1
        if self.lookups == self.fail_at:
            self.failed_in = method
            raise RuntimeError("a bug deep in a transition")

    def get(self, key: int, default: Any = None) -> Any:  # type: ignore[override]
        self._count("get")
        return super().get(key, default)

    def __contains__(self, key: object) -> bool:
        self._count("contains")
        return super().__contains__(key)


def test_a_move_that_raises_inside_the_engine_leaves_its_mover_as_it_was() -> None:
    world = flat_world()
    mid = stand(world, 60.0, 60.0)
    world.mover(mid).velocity = Vec3(1.0, 2.0, 0.0)
    target = world.mover(mid).position.moved(Vec3(0.5, 0.0, 0.0))

    def move_with_velocity() -> None:
        world.move(mid, target, Vec3(3.0, 0.0, 0.0))
        raise AssertionError("the move went through")  # only a failing run may return

    def step() -> None:
        world.step(mid, Vec3(0.1, 0.0, 0.0), 1.0 / 30.0)  # integrates velocity before the transition
        raise AssertionError("the step went through")

    for run in (move_with_velocity, step):
        before = snapshot(world, mid)
        plain = dict(world.landblocks)
        failed_in: set[str] = set()
        for fail_at in range(1, 400):
            blocks = _FailingLookups(plain, fail_at)
            world.landblocks = blocks
            try:
                run()
            except RuntimeError:
                failed_in.add(blocks.failed_in)
                assert snapshot(world, mid) == before, f"{run.__name__} failing at lookup {fail_at}"
                continue
            except AssertionError:
                break  # the run got through: every lookup it makes has failed once
            finally:
                world.landblocks = plain
        # it failed at the door and inside the transition (after the move had changed the mover)
        assert failed_in == {"contains", "get"}, f"{run.__name__}: failed only in {failed_in}"
        assert snapshot(world, mid) != before  # the last run got through and did move it


# -- a move's velocity is that move's only (docs/protocol.md, Move request) ---------------------------------
def test_a_velocity_given_with_a_move_does_not_outlive_it() -> None:
    world = flat_world()
    mid = stand(world, 140.0, 140.0)
    world.move(mid, world.mover(mid).position.moved(Vec3(0.5, 0.0, 0.0)), Vec3(0.0, 30.0, 40.0))
    assert world.mover(mid).velocity == Vec3(0.0, 0.0, 0.0)  # at rest again, as before the move
    # a later physics step from rest on flat ground moves it by its own motion only (a leftover
    # 30 m/s north, 40 m/s up would add 1 m and 1.3 m in this 1/30 s)
    r = world.step(mid, Vec3(0.0, 0.1, 0.0), 1.0 / 30.0)
    o = r.position.origin
    assert (o.x, o.y, o.z) == pytest.approx((140.5, 140.1, 50.0), abs=1e-5)
    assert r.contact and r.on_walkable


def test_the_velocity_a_move_is_given_is_what_the_move_resolves_with() -> None:
    """A move's velocity still matters while it is resolved: moving away from the contact plane faster
    than EPSILON breaks contact (PhysicsObj.check_contact), so the move is resolved airborne and lands
    back on the ground, whose normal it reports as the collision normal."""
    world = flat_world()
    mid = stand(world, 40.0, 40.0)
    up = world.move(mid, world.mover(mid).position.moved(Vec3(0.3, 0.0, 0.0)), Vec3(0.0, 0.0, MAX_VELOCITY))
    mid2 = stand(world, 140.0, 140.0)
    flat = world.move(mid2, world.mover(mid2).position.moved(Vec3(0.3, 0.0, 0.0)))
    assert flat.collision_normal is None
    assert up.collision_normal == Vec3(0.0, 0.0, 1.0)
    assert world.mover(mid).velocity == Vec3(0.0, 0.0, 0.0)


def test_set_velocity_gives_the_mover_its_own_velocity_clamped_to_max_velocity() -> None:
    world = flat_world()
    mid = stand(world, 50.0, 50.0)
    # a 3-4-5 triangle: 100 m/s along (0.6, 0.8) is cut to 50 m/s along the same direction
    assert world.set_velocity(mid, Vec3(60.0, 80.0, 0.0)) == Vec3(30.0, 40.0, 0.0)
    assert world.mover(mid).velocity == Vec3(30.0, 40.0, 0.0)
    assert MAX_VELOCITY == 50.0
    # below the clamp it is kept as given, and it outlives a later move (it is the mover's own)
    world.set_velocity(mid, Vec3(0.0, 3.0, 0.0))
    here = world.mover(mid).position
    world.move(mid, here.with_origin(here.frame.origin + Vec3(0.1, 0.0, 0.0)))
    assert world.mover(mid).velocity == Vec3(0.0, 3.0, 0.0)
    with pytest.raises(NonFiniteError):
        world.set_velocity(mid, Vec3(math.nan, 0.0, 0.0))


def test_a_sliding_normal_is_a_unit_vector_or_zero() -> None:
    """Zero is what a mover settled on level ground slides along (no horizontal direction)."""
    from engine.limits import check_sliding_normal

    assert check_sliding_normal(Vec3(0.0, 0.0, 0.0), "sliding_normal") == Vec3(0.0, 0.0, 0.0)
    assert check_sliding_normal(Vec3(0.6, 0.8, 0.0), "sliding_normal") == Vec3(0.6, 0.8, 0.0)
    for bad in (Vec3(0.3, 0.4, 0.0), Vec3(1e-9, 0.0, 0.0), Vec3(2.0, 0.0, 0.0)):
        with pytest.raises(OutOfRangeError, match="sliding_normal: length"):
            check_sliding_normal(bad, "sliding_normal")
    with pytest.raises(EngineError):
        check_sliding_normal(Vec3(math.nan, 0.0, 0.0), "sliding_normal")
