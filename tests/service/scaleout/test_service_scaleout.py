"""Two instances on loopback splitting the demo world by landblock.

Instance A owns the west landblocks (A9B4, A9B5), B the east ones (AAB4,
AAB5). A mover walking east across x = 192 is handed over from A to B with
its state, and back again; the results equal one engine doing it all.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator

import pytest

from support.cluster_files import cluster_pair
from clients import Client, Move, MoverState, ServiceError
from clients.demo.walk import global_xy
from clients.demo.world import global_to_cell
from engine.geometry import Vec3
from support.service_harness import (
    ServiceProcess,
    comparable,
    demo_world,
    human,
    prime_states,
    raw_query,
    raw_session,
    start_on_ground,
    wait_until,
)

ZERO = (0.0, 0.0, 0.0)


@pytest.fixture(scope="module")
def pair(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[ServiceProcess, ServiceProcess]]:
    # a cluster: the instances reach each other over mutual TLS (service/security/cluster.py), clients over tcp
    a_args, b_args = cluster_pair(tmp_path_factory.mktemp("cluster"))
    with ServiceProcess(own="A9B4,A9B5", extra=a_args) as a:
        with ServiceProcess(own="AAB4,AAB5", extra=b_args) as b:  # joined to A over TLS only
            yield a, b


@pytest.fixture()
def client(pair: tuple[ServiceProcess, ServiceProcess]) -> Iterator[Client]:
    a, _ = pair
    with Client([a.endpoint], timeout=10.0) as c:  # connected to A only: zenoh routes B's keys
        c.wait_ready(instances=2)
        yield c


def _stats(c: Client) -> dict[str, dict]:  # type: ignore[type-arg]
    by_owner = {}
    for s in c.stats():
        owned = next(lb["owned"] for lb in c.landblocks() if lb.instance == s.instance)
        by_owner["A" if 0xA9B4 in owned else "B"] = s.data
    return by_owner


def _walk_on_ground(c: Client, world, gx: float, gy: float):  # type: ignore[no-untyped-def]
    cell, x, y = global_to_cell(gx, gy)
    start = start_on_ground(world, cell, x, y)
    st = c.register(human(), start)
    mid = world.add_mover(human(), start)
    for _ in range(10):  # land, with the engine alongside
        st = c.step(st.id, ZERO, 0.2)
        assert comparable(st) == comparable(world.step(mid, Vec3(*ZERO), 0.2))
    assert st.on_walkable
    return st, mid


def test_handover_across_the_border_and_back(client: Client, pair: tuple[ServiceProcess, ServiceProcess]) -> None:
    a, _ = pair
    before = _stats(client)
    world = demo_world()
    st, mid = _walk_on_ground(client, world, 180.0, 100.0)
    assert st.landblock == 0xA9B4
    path = []
    for dx in [1.0] * 25 + [-1.0] * 25:  # east into AAB4, then back west into A9B4
        st = client.move(st.id, offset=(dx, 0.0, 0.0), velocity=ZERO)
        cur = world.mover_state(mid).position
        direct = world.move(mid, cur.moved(Vec3(dx, 0.0, 0.0)), Vec3(*ZERO))
        assert comparable(st) == comparable(direct)
        path.append(st.landblock)
    assert 0xAAB4 in path and path[-1] == 0xA9B4
    assert st.seq == 10 + 50  # the sequence number travelled with the mover
    after = _stats(client)
    assert after["A"]["handovers"]["out"] - before["A"]["handovers"]["out"] == 1
    assert after["B"]["handovers"]["in"] - before["B"]["handovers"]["in"] == 1
    assert after["B"]["handovers"]["out"] - before["B"]["handovers"]["out"] == 1
    assert after["A"]["handovers"]["in"] - before["A"]["handovers"]["in"] == 1
    client.remove(st.id)


def test_old_owner_answers_moved(client: Client, pair: tuple[ServiceProcess, ServiceProcess]) -> None:
    a, _ = pair
    world = demo_world()
    st, _ = _walk_on_ground(client, world, 188.0, 60.0)
    while st.landblock == 0xA9B4:
        st = client.move(st.id, offset=(1.0, 0.0, 0.0))
    assert st.landblock == 0xAAB4
    import msgpack

    session = raw_session(a.endpoint)
    try:
        ok, reply = raw_query(session, "acphys/lb/A9B4/move",
                              msgpack.packb({"v": 1, "move": {"id": st.id, "offset": [0.1, 0, 0]}}))
    finally:
        session.close()
    assert not ok and reply["error"]["kind"] == "moved" and reply["error"]["landblock"] == 0xAAB4
    # a client that still thinks the mover is in A9B4 follows the redirect
    with Client([a.endpoint]) as other:
        other.wait_ready(instances=2)  # it reaches B once Zenoh's gossip has told it B's endpoint
        other.locate(st.id, 0xA9B4)
        again = other.move(st.id, offset=(0.1, 0.0, 0.0))
        assert again.seq == st.seq + 1 and again.landblock == 0xAAB4
        # a batch too
        res = other.move_many([Move(st.id, offset=(0.1, 0.0, 0.0))])
        assert isinstance(res[0], MoverState) and res[0].seq == st.seq + 2
    client.remove(st.id)


def test_fire_and_forget_across_the_border_keeps_every_state(client: Client) -> None:
    world = demo_world()
    st, _ = _walk_on_ground(client, world, 185.0, 140.0)
    got: list[MoverState] = []
    lock = threading.Lock()

    def on_state(s: MoverState) -> None:
        with lock:
            got.append(s)

    with client.subscribe(on_state, st.id):
        base = prime_states(client, st.id, lambda: list(got))
        got.clear()
        for k in range(40):
            client.push([Move(st.id, offset=(0.5, 0.0, 0.0), tag=k)])
        assert wait_until(lambda: len(got) >= 40, timeout=20.0), len(got)
    assert [s.tag for s in got] == list(range(40))
    assert [s.seq for s in got] == list(range(base + 1, base + 41))
    assert got[0].landblock == 0xA9B4 and got[-1].landblock == 0xAAB4
    assert global_xy(got[-1].position)[0] == pytest.approx(185.0 + 20.0, abs=0.5)
    client.remove(st.id)


def test_no_owner_keeps_the_mover_where_it_was() -> None:
    with ServiceProcess(own="A9B4") as a:
        with Client([a.endpoint]) as c:
            c.wait_ready()
            world = demo_world()
            st, _ = _walk_on_ground(c, world, 190.0, 100.0)
            with pytest.raises(ServiceError) as e:
                for _ in range(5):
                    st = c.move(st.id, offset=(1.0, 0.0, 0.0))
            assert e.value.kind == "no_owner" and e.value.details["landblock"] == 0xAAB4
            state, _ = c.get(st.id)
            assert state.seq == st.seq
            # the same place and contact (a get reports no transition of its own)
            unrun = {"transition_state", "frames_stationary_fall"}
            assert {k: v for k, v in comparable(state).items() if k not in unrun} == \
                   {k: v for k, v in comparable(st).items() if k not in unrun}
            (stats,) = c.stats()
            assert stats["handovers"]["failed"] == 1 and stats["errors"]["no_owner"] == 1
            # it can still walk the other way
            assert c.move(st.id, offset=(-1.0, 0.0, 0.0)).ok
