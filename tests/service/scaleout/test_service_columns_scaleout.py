"""The column form across two instances (A owns A9B4/A9B5, B owns AAB4/AAB5).

A batch in which a mover crosses the border mid-batch: the items after the
hand-over get `moved`, `Client.move_batch` sends them again to the new
owner, and the results equal one engine doing it all, bit for bit. A
column push sent to the old owner after the hand-over is forwarded.
"""

from __future__ import annotations

import struct
import threading
from collections.abc import Iterator
from typing import Any

import msgpack
import numpy as np
import pytest

from clients import Client
from clients.demo.world import global_to_cell
from support.cluster_files import cluster_pair
from engine.geometry import Vec3
from support.service_harness import ServiceProcess, demo_world, human, start_on_ground, wait_until


@pytest.fixture(scope="module")
def pair(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[ServiceProcess, ServiceProcess]]:
    a_args, b_args = cluster_pair(tmp_path_factory.mktemp("cluster"))  # instances hand over only in a cluster
    with ServiceProcess(own="A9B4,A9B5", extra=a_args) as a:
        with ServiceProcess(own="AAB4,AAB5", extra=b_args) as b:
            yield a, b


@pytest.fixture()
def client(pair: tuple[ServiceProcess, ServiceProcess]) -> Iterator[Client]:
    a, _ = pair
    with Client([a.endpoint], timeout=10.0) as c:
        c.wait_ready(instances=2)
        yield c


def _bits(v: Any) -> bytes:
    return struct.pack("<3d", *(float(c) for c in v))


def test_batch_follows_a_hand_over_mid_batch(client: Client) -> None:
    world = demo_world()
    starts = []
    for gx, gy in ((188.0, 100.0), (150.0, 120.0)):  # the first walks east across x = 192; the second stays
        cell, x, y = global_to_cell(gx, gy)
        starts.append(start_on_ground(world, cell, x, y))
    ids = [client.register(human(), p).id for p in starts]
    local = [world.add_mover(human(), p) for p in starts]
    zero = np.zeros((2, 3))
    for _ in range(10):  # land, with the engine alongside
        client.move_batch(ids, motions=zero, dt=0.2)
        for m in local:
            world.step(m, Vec3(0.0, 0.0, 0.0), 0.2)
    # one request: the walker's moves 1 m each, interleaved with the other's zero moves
    order = [0, 1, 0, 0, 1, 0, 0, 0, 0, 0, 1, 0]
    batch_ids = [ids[k] for k in order]
    offsets = np.array([[1.0, 0.0, 0.0] if k == 0 else [0.0, 0.0, 0.0] for k in order])
    r = client.move_batch(batch_ids, offsets=offsets)
    assert r.errors == {}
    assert r.landblock[0] == 0xA9B4 and r.landblock[-1] == 0xAAB4  # it crossed during the batch
    seen = {0: 10, 1: 10}
    for i, k in enumerate(order):
        cur = world.mover_state(local[k]).position
        direct = world.move(local[k], cur.moved(Vec3(*offsets[i])))
        seen[k] += 1
        assert int(r.seq[i]) == seen[k], (i, r.seq.tolist(), r.landblock.tolist())
        o = direct.position.frame.origin
        assert _bits(r.origin[i]) == _bits((o.x, o.y, o.z)) and int(r.cell[i]) == direct.position.cell_id, i
    assert client.landblock_of(ids[0]) == 0xAAB4
    for mid in ids:
        client.remove(mid)


def test_column_push_to_the_old_owner_is_forwarded(client: Client) -> None:
    world = demo_world()
    cell, x, y = global_to_cell(195.0, 140.0)  # in AAB4: owned by B
    mid = client.register(human(), start_on_ground(world, cell, x, y)).id
    # walk it west into A9B4 and back east, so A remembers it went to B
    client.move_batch([mid] * 6, offsets=[[-1.0, 0.0, 0.0]] * 6)
    assert client.landblock_of(mid) == 0xA9B4
    client.move_batch([mid] * 6, offsets=[[1.0, 0.0, 0.0]] * 6)
    assert client.landblock_of(mid) == 0xAAB4
    seq = client.get(mid)[0].seq
    got: list[int] = []
    lock = threading.Lock()

    def on_state(st: Any) -> None:
        with lock:
            got.append(st.seq)

    sub = client.subscribe(on_state, mid)
    try:
        payload = msgpack.packb({"v": 1, "kind": "offset", "columns": {
            "id": struct.pack("<Q", mid), "offset": struct.pack("<3d", 0.0, 0.1, 0.0)}}, use_bin_type=True)
        sent = 0
        while sent < 20 and not got:  # the subscription may need a moment to be known
            client.session.put(client.keys.push(0xA9B4), payload)  # A's key: A forwards it to B
            sent += 1
            wait_until(lambda: bool(got), timeout=0.5)
        assert got, "no state from the forwarded push"
        assert wait_until(lambda: client.get(mid)[0].seq == seq + sent, timeout=5.0)
        with lock:
            assert min(got) > seq
    finally:
        sub.close()
        client.remove(mid)
