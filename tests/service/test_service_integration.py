"""The service as a subprocess, driven through the client library.

Results through the service must equal the engine called directly with the
same inputs, states must arrive in order, and the mover lifecycle works.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator

import pytest

from clients import Client, Move, MoverState, ServiceError
from clients.demo.world import global_to_cell
from engine.geometry import Position, Quat, Vec3
from support.service_harness import ServiceProcess, comparable, demo_world, human, prime_states, start_on_ground, wait_until


@pytest.fixture()
def client(service: ServiceProcess) -> Iterator[Client]:
    with Client([service.endpoint], timeout=10.0) as c:
        c.wait_ready()
        yield c


def _script(mover_id: int) -> list[Move]:
    """A mix of physics steps (a fall, then walking), offsets and absolute targets."""
    moves = [Move(mover_id, motion=(0.0, 0.0, 0.0), dt=0.2) for _ in range(8)]
    moves += [Move(mover_id, motion=(0.6, 0.3, 0.0), dt=0.2) for _ in range(25)]
    moves += [Move(mover_id, offset=(0.5, -0.2, 0.0)) for _ in range(10)]
    return moves


def _apply_direct(world, mid: int, m: Move):  # type: ignore[no-untyped-def]
    cur = world.mover_state(mid).position
    if m.motion is not None:
        return world.step(mid, Vec3(*m.motion), m.dt)
    if m.offset is not None:
        return world.move(mid, cur.moved(Vec3(*m.offset)))
    assert m.to is not None
    return world.move(mid, m.to)


def test_single_moves_equal_the_engine(client: Client) -> None:
    world = demo_world()
    cell, x, y = global_to_cell(40.0, 50.0)
    start = start_on_ground(world, cell, x, y)
    st = client.register(human(), start)
    mid = world.add_mover(human(), start)
    assert comparable(st) == comparable(world.mover_state(mid))
    for m in _script(st.id):
        got = client.send(m)
        assert comparable(got) == comparable(_apply_direct(world, mid, m))
    # an absolute target with a new orientation, in the current cell
    target = Position.at(got.position.cell_id, got.position.origin + Vec3(1.0, 1.0, 0.0), Quat.from_heading(90.0))
    got = client.move(st.id, target)
    assert comparable(got) == comparable(world.move(mid, target))
    assert got.on_walkable and got.contact
    client.remove(st.id)


def test_batch_equals_the_engine(client: Client) -> None:
    world = demo_world()
    starts = []
    for gx, gy in ((60.0, 60.0), (64.0, 60.0)):
        cell, x, y = global_to_cell(gx, gy)
        starts.append(start_on_ground(world, cell, x, y))
    ids = [client.register(human(), p).id for p in starts]
    mids = [world.add_mover(human(), p) for p in starts]
    # interleave the two movers' scripts in one batch
    scripts = [_script(i) for i in ids]
    batch = [m for pair in zip(*scripts) for m in pair]
    results = client.move_many(batch)
    assert len(results) == len(batch)
    by_id = dict(zip(ids, mids))
    for m, r in zip(batch, results):
        assert isinstance(r, MoverState), r
        assert r.id == m.id
        assert comparable(r) == comparable(_apply_direct(world, by_id[m.id], m))
    # seq counts this mover's moves only
    assert [r.seq for r in results if r.id == ids[0]] == list(range(1, len(scripts[0]) + 1))
    for i in ids:
        client.remove(i)


def test_batch_item_errors_stay_with_their_item(client: Client) -> None:
    cell, x, y = global_to_cell(80.0, 80.0)
    st = client.register(human(), Position.at(cell, Vec3(x, y, 60.0)))
    results = client.move_many([
        Move(st.id, offset=(0.1, 0.0, 0.0), tag="a"),
        Move(st.id, offset=(float("nan"), 0.0, 0.0), tag="b"),
        Move(st.id, offset=(0.1, 0.0, 0.0), tag="c"),
    ])
    assert isinstance(results[0], MoverState) and results[0].tag == "a" and results[0].seq == 1
    assert isinstance(results[1], ServiceError) and results[1].kind == "non_finite"
    assert results[1].path == "moves[1].offset[0]"
    assert isinstance(results[2], MoverState) and results[2].tag == "c" and results[2].seq == 2
    client.remove(st.id)


def test_batch_as_maps_equals_the_objects(client: Client) -> None:
    """The lean batch call gives the entries the service sent: the same States as `move_many` would build,
    errors as their maps, in order."""
    world = demo_world()
    cell, x, y = global_to_cell(90.0, 60.0)
    start = start_on_ground(world, cell, x, y)
    st = client.register(human(), start)
    mid = world.add_mover(human(), start)
    script = _script(st.id)
    batch = script[:20] + [Move(st.id, offset=(float("inf"), 0.0, 0.0), tag="bad")] + script[20:]
    entries = client.move_many_maps(batch)
    assert len(entries) == len(batch)
    seq = 0
    for m, e in zip(batch, entries):
        assert isinstance(e, dict), e
        if m.tag == "bad":
            assert e["id"] == st.id and e["tag"] == "bad" and e["error"]["kind"] == "non_finite"
            assert e["error"]["path"] == "moves[20].offset[0]"
            continue
        seq += 1
        assert e["id"] == st.id and e["seq"] == seq and "error" not in e
        assert comparable(MoverState.from_wire(e)) == comparable(_apply_direct(world, mid, m))
    assert client.landblock_of(st.id) == entries[-1]["landblock"]  # learned for routing
    client.remove(st.id)


def test_states_are_published_in_order(client: Client) -> None:
    world = demo_world()
    cell, x, y = global_to_cell(100.0, 40.0)
    start = start_on_ground(world, cell, x, y)
    st = client.register(human(), start)
    mid = world.add_mover(human(), start)
    got: list[MoverState] = []
    lock = threading.Lock()

    def on_state(s: MoverState) -> None:
        with lock:
            got.append(s)

    moves = [Move(st.id, motion=(0.3, 0.1, 0.0), dt=0.1, tag=i) for i in range(300)]
    with client.subscribe(on_state, st.id):
        base = prime_states(client, st.id, lambda: list(got))
        world.move(mid, world.mover_state(mid).position)  # the priming zero moves, for the engine too
        got.clear()
        for k in range(0, len(moves), 25):
            client.push(moves[k:k + 25])  # fire-and-forget, in batches of 25
        assert wait_until(lambda: len(got) >= len(moves), timeout=20.0), f"{len(got)} of {len(moves)} states"
    assert [s.seq for s in got] == list(range(base + 1, base + len(moves) + 1))
    assert [s.tag for s in got] == list(range(len(moves)))
    for m, s in zip(moves, got):
        assert comparable(s) == comparable(_apply_direct(world, mid, m))
    client.remove(st.id)


def test_batch_publication_through_the_client(client: Client) -> None:
    cell, x, y = global_to_cell(110.0, 70.0)
    st = client.register(human(), Position.at(cell, Vec3(x, y, 60.0)))
    got: list[list[MoverState]] = []
    lock = threading.Lock()

    def on_batch(states: list[MoverState]) -> None:
        with lock:
            got.append(states)

    with client.subscribe_batches(on_batch):
        deadline_ok = False
        for _ in range(50):  # until the subscription is live
            client.move_many([Move(st.id, offset=(0.0, 0.0, 0.0))], publish="batch")
            if wait_until(lambda: bool(got), timeout=0.2):
                deadline_ok = True
                break
        assert deadline_ok
        with lock:
            got.clear()
        results = client.move_many([Move(st.id, offset=(0.1, 0.0, 0.0), tag=k) for k in range(5)], publish="batch")
        assert wait_until(lambda: bool(got), timeout=5.0)
    assert len(got) == 1
    assert [(s.seq, s.tag) for s in got[0]] == [(r.seq, r.tag) for r in results if isinstance(r, MoverState)]
    assert [s.tag for s in got[0]] == list(range(5))
    client.remove(st.id)


def test_mover_lifecycle(client: Client) -> None:
    cell, x, y = global_to_cell(120.0, 120.0)
    pos = Position.at(cell, Vec3(x, y, 60.0))
    st = client.register(human(), pos, mover_id=0x50000001)
    assert st.id == 0x50000001 and st.seq == 0 and st.transition_state == "NoTransition"
    with pytest.raises(ServiceError) as e:
        client.register(human(), pos, mover_id=0x50000001)
    assert e.value.kind == "duplicate_mover"
    state, spec = client.get(st.id)
    assert state.position.origin.x == pytest.approx(x) and spec["state"] == ["IsPlayer"]
    bigger = human()
    bigger.spheres[0] = type(bigger.spheres[0])((0.0, 0.0, 0.6), 0.6)
    client.update(st.id, bigger)
    assert client.get(st.id)[1]["spheres"][0]["radius"] == 0.6
    client.move(st.id, offset=(0.5, 0.0, 0.0))
    client.remove(st.id)
    with pytest.raises(ServiceError) as e:
        client.remove(st.id)
    assert e.value.kind == "unknown_mover"
    client.locate(st.id, cell >> 16)
    with pytest.raises(ServiceError) as e:
        client.move(st.id, offset=(0.5, 0.0, 0.0))
    assert e.value.kind == "unknown_mover"


def test_find_locates_a_mover_seen_by_another_client(client: Client, service: ServiceProcess) -> None:
    cell, x, y = global_to_cell(150.0, 150.0)
    st = client.register(human(), Position.at(cell, Vec3(x, y, 60.0)))
    with Client([service.endpoint]) as other:
        moved = other.move(st.id, offset=(0.1, 0.0, 0.0))  # no locate(): the client asks every instance
        assert moved.seq == 1
    client.remove(st.id)


def test_landblocks_health_and_stats(client: Client) -> None:
    (lbs,) = client.landblocks()
    assert lbs["owned"] == "*" and lbs["loaded"] == [0xA9B4, 0xA9B5, 0xAAB4, 0xAAB5]
    assert client.load_landblock(0xA9B4) is True  # already loaded: a cache hit
    with pytest.raises(ServiceError) as e:
        client.load_landblock(0x1234)
    assert e.value.kind == "landblock_unavailable"
    (health,) = client.health()
    assert health["status"] == "ok" and health["protocol"] == 1
    (stats,) = client.stats()
    assert stats["moves"] > 0 and stats["requests"]["move"] > 0
    assert stats["latency_ms"]["p50"] > 0 and stats["latency_ms"]["p99"] >= stats["latency_ms"]["p50"]
    assert stats["cache"]["hits"] >= 1 and stats["cache"]["misses"] >= 1
    assert stats["errors"].get("landblock_unavailable", 0) >= 1
    assert stats["loaded_landblocks"] == [0xA9B4, 0xA9B5, 0xAAB4, 0xAAB5]


def test_unload_refuses_a_landblock_with_movers(client: Client) -> None:
    cell, x, y = global_to_cell(10.0, 200.0)  # landblock A9B5
    st = client.register(human(), Position.at(cell, Vec3(x, y, 60.0)))
    with pytest.raises(ServiceError) as e:
        client.unload_landblock(0xA9B5)
    assert e.value.kind == "landblock_in_use" and st.id in e.value.details["movers"]
    client.remove(st.id)
