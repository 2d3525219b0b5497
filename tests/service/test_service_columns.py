"""The column form of a move batch (docs/protocol.md, "Column batches").

- the doc's column tables, flag bits, state codes and worked hex example
  against the one declaration in service/protocol/columns.py;
- the request checks without a service (service/protocol/column_request.py);
- against a running service: the same moves through the map form and the
  column form give the same States bit for bit; bad input fails its item
  (or the whole request) and changes nothing it concerns; the columnar
  publication; a raw client that uses only msgpack and struct.
"""

from __future__ import annotations

import math
import re
import struct
import threading
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import msgpack
import numpy as np
import pytest
import zenoh

from clients import Client, Move
from clients.batch import BatchResults
from clients.demo.world import global_to_cell
from engine.geometry import Position, Quat, Vec3
from service.protocol.column_request import parse_column_request
from service.protocol.columns import REPLY_COLUMNS, REQUEST_COLUMNS, TRANSIENT_FLAGS, TRANSITION_STATES, Flag
from service.protocol.errors import ProtocolError
from support.service_harness import ServiceProcess, demo_world, human, raw_session, start_on_ground, wait_until

DOC = Path(__file__).resolve().parents[2] / "docs" / "protocol.md"
P = "acphys"


# -- the document against the declaration ---------------------------------------------------------
def _doc_section(heading: str) -> str:
    text = DOC.read_text(encoding="utf-8")
    start = text.index(f"\n{heading}\n")
    nxt = re.search(r"\n#{2,4} ", text[start + len(heading) + 2:])
    return text[start:start + len(heading) + 2 + (nxt.start() if nxt else len(text))]


def _table(section: str) -> list[list[str]]:
    rows = [ln for ln in section.splitlines() if ln.startswith("|")]
    return [[c.strip().strip("`") for c in r.strip("|").split("|")] for r in rows[2:]]  # skip header, rule


def test_doc_request_table_matches_declaration() -> None:
    rows = _table(_doc_section("#### Request columns"))
    assert [r[0] for r in rows] == [c.name for c in REQUEST_COLUMNS]
    for r, col in zip(rows, REQUEST_COLUMNS):
        assert (r[1], int(r[2])) == (col.dtype, col.width), col.name
        for kind, cell in zip(("offset", "to", "motion"), r[3:6]):
            want = "required" if kind in col.required else "optional" if kind in col.optional else "—"
            assert cell == want, (col.name, kind)


def test_doc_reply_table_matches_declaration() -> None:
    rows = _table(_doc_section("#### Column reply"))
    assert [r[0] for r in rows] == [c.name for c in REPLY_COLUMNS]
    for r, col in zip(rows, REPLY_COLUMNS):
        assert (r[1], int(r[2]), r[3]) == (col.dtype, col.width, col.missing), col.name


def test_doc_flag_bits_and_state_codes_match_declaration() -> None:
    section = _doc_section("#### Column reply")
    flags_text = section[section.index("`flags` bits"):section.index("`transition_state` codes")]
    flags_text = " ".join(flags_text.split())
    named = {"resolved": Flag.RESOLVED, "`ok`": Flag.OK, "`contact`": Flag.CONTACT,
             "`on_walkable`": Flag.ON_WALKABLE, "`water_contact`": Flag.WATER_CONTACT,
             "`contact_plane` given": Flag.HAS_CONTACT_PLANE, "`contact_plane_cell` given": Flag.HAS_CONTACT_PLANE_CELL,
             "`collision_normal` given": Flag.HAS_COLLISION_NORMAL, "`sliding_normal` given": Flag.HAS_SLIDING_NORMAL,
             "`frames_stationary_fall` given": Flag.HAS_FRAMES_STATIONARY_FALL}
    for words, bit in named.items():
        m = re.search(r"(\d+) " + re.escape(words) + r"[ ,;(]", flags_text)
        assert m is not None, words
        assert 1 << int(m.group(1)) == bit, words
    for k, name in enumerate(TRANSIENT_FLAGS):
        m = re.search(r"(\d+) `" + name + "`", flags_text)
        assert m is not None and int(m.group(1)) == Flag.TRANSIENT_SHIFT + k, name
    codes_text = " ".join(section[section.index("`transition_state` codes"):].split())
    for code, name in enumerate(TRANSITION_STATES):
        assert re.search(rf"\b{code} `{name}`", codes_text), name
    assert "255 for a failed item" in codes_text


def test_doc_worked_example_is_the_request_it_describes() -> None:
    section = _doc_section("#### Worked example")
    block = section.split("```")[1]
    data = bytes.fromhex(" ".join(block.split()))
    want = {"v": 1, "kind": "offset",
            "columns": {"id": struct.pack("<Q", 7), "offset": struct.pack("<3d", 1.0, 0.0, -0.5)}}
    assert msgpack.unpackb(data, raw=False) == want
    assert len(data) == int(re.search(r"is these (\d+) bytes", section).group(1))  # type: ignore[union-attr]
    req = parse_column_request(msgpack.unpackb(data, raw=False))
    assert req.kind == "offset" and req.n == 1 and req.arrays["id"].tolist() == [7]
    assert req.arrays["offset"].tolist() == [[1.0, 0.0, -0.5]]


# -- request checks without a service -------------------------------------------------------------
def _msg(kind: str = "offset", n: int = 10, **columns: Any) -> dict[str, Any]:
    cols: dict[str, Any] = {"id": struct.pack(f"<{n}Q", *range(1, n + 1))}
    if kind == "offset":
        cols["offset"] = struct.pack(f"<{3 * n}d", *([0.25, 0.0, 0.0] * n))
    elif kind == "to":
        cols["to_origin"] = struct.pack(f"<{3 * n}d", *([30.0, 30.0, 50.0] * n))
    else:
        cols["motion"] = struct.pack(f"<{3 * n}d", *([0.0, 1.0, 0.0] * n))
        cols["dt"] = struct.pack(f"<{n}d", *([0.05] * n))
    cols.update(columns)
    return {"v": 1, "kind": kind, "columns": cols}


def _refused(msg: dict[str, Any]) -> ProtocolError:
    with pytest.raises(ProtocolError) as ei:
        parse_column_request(msg)
    return ei.value


def test_request_level_errors_name_the_column() -> None:
    e = _refused(_msg(offset=[0.25, 0.0, 0.0] * 10))
    assert (e.kind, e.path) == ("wrong_type", "columns.offset") and "binary" in e.message
    e = _refused(_msg(offset=b"\x00" * 239))
    assert (e.kind, e.path) == ("bad_value", "columns.offset")
    e = _refused(_msg(offset=b"\x00" * 24 * 9))
    assert (e.kind, e.path) == ("bad_value", "columns.offset") and "9 items" in e.message
    e = _refused(_msg(velocity=b"\x00" * 24 * 11))
    assert (e.kind, e.path) == ("bad_value", "columns.velocity")
    e = _refused(_msg("motion", dt=None))
    assert (e.kind, e.path) == ("missing_field", "columns.dt")
    e = _refused(_msg("motion", velocity=b"\x00" * 240))
    assert (e.kind, e.path) == ("bad_value", "columns.velocity")
    e = _refused(_msg(n=4097))
    assert (e.kind, e.path) == ("too_large", "columns.id")
    e = _refused({**_msg(), "kind": "jump"})
    assert (e.kind, e.path) == ("bad_value", "kind")
    e = _refused({**_msg(), "publish": "loud"})
    assert (e.kind, e.path) == ("bad_value", "publish")
    e = _refused({**_msg(), "moves": []})
    assert e.kind == "bad_value"
    e = _refused({"v": 1, "kind": "offset", "columns": [1, 2]})
    assert (e.kind, e.path) == ("wrong_type", "columns")


def test_item_level_errors_name_column_index_and_component() -> None:
    off = [[0.25, 0.0, 0.0] for _ in range(10)]
    off[7][0] = math.nan
    off[3][2] = 1e39
    off[5][1] = -math.inf
    req = parse_column_request(_msg(offset=struct.pack("<30d", *sum(off, []))))
    assert sorted(req.bad) == [3, 5, 7]
    assert (req.bad[7].kind, req.bad[7].path) == ("non_finite", "columns.offset[7][0]")
    assert (req.bad[5].kind, req.bad[5].path) == ("non_finite", "columns.offset[5][1]")
    assert (req.bad[3].kind, req.bad[3].path) == ("bad_value", "columns.offset[3][2]")
    assert "float32" in req.bad[3].message
    # just inside float32's range is accepted
    ok = parse_column_request(_msg(offset=struct.pack("<30d", *([3.4e38, 0.0, 0.0] * 10))))
    assert ok.bad == {}
    dts = [0.05] * 10
    dts[2], dts[4] = 0.0, 61.0
    req = parse_column_request(_msg("motion", dt=struct.pack("<10d", *dts)))
    assert {i: (e.kind, e.path) for i, e in req.bad.items()} == {
        2: ("bad_value", "columns.dt[2]"), 4: ("bad_value", "columns.dt[4]")}
    quats = [[0.0, 0.0, 0.0, 0.0]] * 10
    quats = [list(q) for q in quats]
    quats[1] = [1.0, 0.0, 0.0, 0.0]
    quats[6] = [0.9, 0.0, 0.0, 0.0]
    req = parse_column_request(_msg("to", to_orientation=struct.pack("<40d", *sum(quats, []))))
    assert {i: (e.kind, e.path) for i, e in req.bad.items()} == {6: ("bad_value", "columns.to_orientation[6]")}


# -- against a running service ----------------------------------------------------------------------
@pytest.fixture(scope="module")
def client(service: ServiceProcess) -> Iterator[Client]:
    with Client([service.endpoint], timeout=20.0) as c:
        c.wait_ready()
        yield c


#: start spots (global demo metres): a row of walkers, and two pairs close enough to bump into each other
SPOTS = [(60.0 + 8.0 * k, 60.0) for k in range(6)] + [(60.0, 80.0), (61.2, 80.0), (90.0, 80.0), (90.0, 81.1)]


_WORLD: list[Any] = []


def _on_ground(x: float, y: float) -> Position:
    """Half a metre above the demo world's terrain at global (x, y)."""
    if not _WORLD:
        _WORLD.append(demo_world())
    cell, lx, ly = global_to_cell(x, y)
    return start_on_ground(_WORLD[0], cell, lx, ly)


def _solid() -> Any:
    """A human-sized mover that is not a player (players pass through each other)."""
    return replace(human(), state=[])


def _register_all(c: Client) -> list[int]:
    return [c.register(human() if k < 6 else _solid(), _on_ground(x, y)).id for k, (x, y) in enumerate(SPOTS)]


def _bits(x: float) -> bytes:
    return struct.pack("<d", x)


def _vec(v: Any) -> tuple[bytes, ...] | None:
    return None if v is None else tuple(_bits(float(c)) for c in v)


def _from_map(st: dict[str, Any]) -> dict[str, Any]:
    """What must agree, from a State map; floats as their bytes."""
    cp = st["contact_plane"]
    return {
        "seq": st["seq"], "ok": st["ok"], "cell": st["position"]["cell"],
        "origin": _vec(st["position"]["origin"]), "orientation": _vec(st["position"]["orientation"]),
        "transition_state": st["transition_state"], "contact": st["contact"], "on_walkable": st["on_walkable"],
        "contact_plane": None if cp is None else _vec([*cp["normal"], cp["d"]]),
        "contact_plane_cell": st["contact_plane_cell"], "collision_normal": _vec(st["collision_normal"]),
        "sliding_normal": _vec(st["sliding_normal"]), "water_contact": st["water_contact"],
        "frames_stationary_fall": st["frames_stationary_fall"], "transient_state": list(st["transient_state"]),
        "collide_count": len(st["collide_objects"]),
    }


def _from_columns(r: BatchResults, i: int) -> dict[str, Any]:
    """The same from row i of the column reply, read by the documented bits and codes."""
    f = int(r.flags[i])
    assert f & 1, f"item {i} failed: {r.errors.get(i)}"
    has = lambda bit: bool(f & (1 << bit))  # noqa: E731
    return {
        "seq": int(r.seq[i]), "ok": has(1), "cell": int(r.cell[i]),
        "origin": _vec(r.origin[i]), "orientation": _vec(r.orientation[i]),
        "transition_state": ["OK", "Collided", "Adjusted", "Slid", "Invalid", "NoTransition"][r.transition_state[i]],
        "contact": has(2), "on_walkable": has(3),
        "contact_plane": _vec(r.contact_plane[i]) if has(5) else None,
        "contact_plane_cell": int(r.contact_plane_cell[i]) if has(6) else None,
        "collision_normal": _vec(r.collision_normal[i]) if has(7) else None,
        "sliding_normal": _vec(r.sliding_normal[i]) if has(8) else None,
        "water_contact": has(4),
        "frames_stationary_fall": int(r.frames_stationary_fall[i]) if has(9) else None,
        "transient_state": [n for k, n in enumerate(["Contact", "OnWalkable", "Sliding", "WaterContact",
                                                     "StationaryFall", "StationaryStop", "StationaryStuck"])
                            if has(16 + k)],
        "collide_count": int(r.collide_count[i]),
    }


def _rounds(n: int) -> list[dict[str, Any]]:
    """Falls, then walks by offset (the pairs toward each other), then targets, then steps with motion."""
    rng = np.random.default_rng(5)
    out: list[dict[str, Any]] = [{"motions": np.zeros((n, 3)), "dt": np.full(n, 0.1)} for _ in range(8)]
    toward = np.zeros((n, 3))
    toward[6:10, 0] = [0.3, -0.3, 0.0, 0.0]
    toward[8:10, 1] = [0.3, -0.3]
    for k in range(12):
        off = rng.uniform(-0.25, 0.25, (n, 3))
        off[:, 2] = 0.0
        off[6:10] = toward[6:10]
        out.append({"offsets": off, "velocities": None if k % 3 else rng.uniform(-1, 1, (n, 3))})
    out.append({"targets": "drift"})
    for _ in range(6):
        out.append({"motions": np.tile([0.0, 2.0, 0.0], (n, 1)), "dt": rng.uniform(0.02, 0.1, n)})
    return out


def test_column_form_equals_map_form_bit_for_bit(client: Client) -> None:
    """Two identical sets of movers, one after the other at the same spots: the map form's States and the
    column form's rows agree in every field."""
    n = len(SPOTS)
    rounds = _rounds(n)
    runs: dict[str, list[list[dict[str, Any]]]] = {"map": [], "columns": []}
    for form in ("map", "columns"):
        ids = _register_all(client)
        for rnd in rounds:
            args = dict(rnd)
            if args.get("targets") == "drift":  # targets: where each one is, moved 0.2 m, turned 90 degrees
                states = [client.get(i)[0] for i in ids]
                h = math.sqrt(0.5)
                args = {"targets": np.array([[s.position.frame.origin.x + 0.2, s.position.frame.origin.y,
                                              s.position.frame.origin.z] for s in states]),
                        "cells": np.array([s.position.cell_id for s in states]),
                        "orientations": np.tile([h, 0.0, 0.0, h], (n, 1))}
            if form == "map":
                moves = []
                for k, mid in enumerate(ids):
                    if "offsets" in args:
                        vel = args.get("velocities")
                        moves.append(Move(mid, offset=tuple(args["offsets"][k]),
                                          velocity=None if vel is None else tuple(vel[k])))
                    elif "targets" in args:
                        x, y, z = args["targets"][k]
                        moves.append(Move(mid, to=Position.at(int(args["cells"][k]), Vec3(x, y, z),
                                                              Quat(*args["orientations"][k]))))
                    else:
                        moves.append(Move(mid, motion=tuple(args["motions"][k]), dt=float(args["dt"][k])))
                entries = client.move_many_maps(moves)
                assert all(isinstance(e, dict) and "error" not in e for e in entries), entries
                runs[form].append([_from_map(e) for e in entries])  # type: ignore[arg-type]
            else:
                res = client.move_batch(ids, **args)
                assert res.errors == {}
                runs[form].append([_from_columns(res, k) for k in range(n)])
        for mid in ids:
            client.remove(mid)
    assert len(runs["map"]) == len(rounds)
    for k, (a, b) in enumerate(zip(runs["map"], runs["columns"])):
        assert a == b, f"round {k} differs"
    # the workload exercised what it was meant to: ground contact, collisions between movers, slides
    last = runs["map"]
    assert any(s["on_walkable"] for rnd in last for s in rnd)
    assert any(s["collide_count"] for rnd in last for s in rnd)
    assert any(s["collision_normal"] is not None for rnd in last for s in rnd)


def test_collide_ids_name_the_other_mover(client: Client) -> None:
    a = client.register(_solid(), _on_ground(150.0, 150.0)).id
    b = client.register(_solid(), _on_ground(151.2, 150.0)).id
    try:
        client.move_batch([a, b], motions=np.zeros((2, 3)), dt=0.1)
        for _ in range(10):
            client.move_batch([a, b], motions=np.zeros((2, 3)), dt=0.1)
        seen: set[tuple[int, int]] = set()
        for _ in range(6):
            r = client.move_batch([a, b], offsets=[[0.25, 0.0, 0.0], [-0.25, 0.0, 0.0]])
            for i, mid in enumerate((a, b)):
                seen.update((mid, other) for other in r.collide_objects(i))
        assert (a, b) in seen and (b, a) in seen
    finally:
        client.remove(a)
        client.remove(b)


def _snapshot(c: Client, ids: list[int]) -> list[tuple[int, bytes]]:
    out = []
    for mid in ids:
        st = c.get(mid)[0]
        o = st.position.frame.origin
        out.append((st.seq, struct.pack("<3d", o.x, o.y, o.z)))
    return out


@pytest.fixture()
def ten(client: Client) -> Iterator[list[int]]:
    ids = []
    for k in range(10):
        ids.append(client.register(human(), _on_ground(250.0 + 4.0 * k, 250.0)).id)
    client.move_batch(ids, motions=np.zeros((10, 3)), dt=0.1)
    yield ids
    for mid in ids:
        client.remove(mid)


def test_bad_item_changes_only_nothing_of_its_mover(client: Client, ten: list[int]) -> None:
    before = _snapshot(client, ten)
    off = np.tile([0.2, 0.0, 0.0], (10, 1))
    off[7, 0] = np.nan
    off[2, 1] = 5e38
    ids = list(ten)
    ids[4] = 0xDEADBEEF  # nobody
    r = client.move_batch(ids, offsets=off)
    assert sorted(r.errors) == [2, 4, 7]
    assert (r.errors[7].kind, r.errors[7].path) == ("non_finite", "columns.offset[7][0]")  # type: ignore[attr-defined]
    assert (r.errors[2].kind, r.errors[2].path) == ("bad_value", "columns.offset[2][1]")  # type: ignore[attr-defined]
    assert r.errors[4].kind == "unknown_mover"  # type: ignore[attr-defined]  # found out by the client's find
    assert not r.resolved[[2, 4, 7]].any() and r.resolved[[0, 1, 3, 5, 6, 8, 9]].all()
    assert np.isnan(r.origin[7]).all() and r.transition_state[7] == 255
    after = _snapshot(client, ten)
    for k in range(10):
        if k in (2, 7):
            assert after[k] == before[k], k
        elif k != 4:
            assert after[k][0] == before[k][0] + 1
            assert int(r.seq[k]) == after[k][0]


def _raw_columns(c: Client, lb: int, body: dict[str, Any]) -> tuple[bool, dict[str, Any]]:
    (reply,) = list(c.session.get(c.keys.move(lb), payload=msgpack.packb({"v": 1, **body}, use_bin_type=True),
                                  timeout=10.0))
    if reply.ok is not None:
        return True, msgpack.unpackb(reply.ok.payload.to_bytes(), raw=False)
    return False, msgpack.unpackb(reply.err.payload.to_bytes(), raw=False)


def test_request_level_error_changes_nothing(client: Client, ten: list[int]) -> None:
    before = _snapshot(client, ten)
    lb = client.landblock_of(ten[0])
    ids = struct.pack("<10Q", *ten)
    good = struct.pack("<30d", *([0.2, 0.0, 0.0] * 10))
    cases = [
        ({"offset": [0.2, 0.0, 0.0] * 10}, "wrong_type", "columns.offset"),
        ({"offset": good[:-1]}, "bad_value", "columns.offset"),
        ({"offset": good[:-24]}, "bad_value", "columns.offset"),
        ({"offset": good, "velocity": b"\x00" * 24}, "bad_value", "columns.velocity"),
        ({"offset": good, "dt": struct.pack("<10d", *([0.1] * 10))}, "bad_value", "columns.dt"),
    ]
    for extra, kind, path in cases:
        ok, msg = _raw_columns(client, lb, {"kind": "offset", "columns": {"id": ids, **extra}})
        assert not ok and (msg["error"]["kind"], msg["error"].get("path")) == (kind, path), msg
    big = 4097
    ok, msg = _raw_columns(client, lb, {"kind": "offset", "columns": {
        "id": struct.pack(f"<{big}Q", *([ten[0]] * big)), "offset": b"\x00" * 24 * big}})
    assert not ok and msg["error"]["kind"] == "too_large"
    assert _snapshot(client, ten) == before


def test_raw_client_reads_the_reply_by_the_document(client: Client, ten: list[int]) -> None:
    """Only msgpack and struct: the byte layouts as docs/protocol.md gives them."""
    lb = client.landblock_of(ten[0])
    st = client.get(ten[0])[0]
    o = st.position.frame.origin
    ok, msg = _raw_columns(client, lb, {"kind": "offset", "columns": {
        "id": struct.pack("<3Q", ten[0], 0xDEADBEEF, ten[1]), "offset": b"\x00" * 72}})
    assert ok and [(e["index"], e["id"], e["error"]["kind"], e["error"]["path"]) for e in msg["errors"]] == [
        (1, 0xDEADBEEF, "unknown_mover", "columns.id[1]")]
    st = client.get(ten[0])[0]
    o = st.position.frame.origin
    ok, msg = _raw_columns(client, lb, {"kind": "to", "columns": {
        "id": struct.pack("<2Q", ten[0], ten[1]),
        "to_origin": struct.pack("<6d", o.x + 0.1, o.y, o.z, 10.0, 10.0, 50.0),
        "to_cell": struct.pack("<2I", 0, 0x12340001)}})  # item 1: a landblock nobody loaded
    assert ok, msg
    cols = msg["columns"]
    assert msg["n"] == 2 and [e["index"] for e in msg["errors"]] == [1] and msg["errors"][0]["id"] == ten[1]
    assert msg["errors"][0]["error"]["kind"] in ("landblock_not_loaded", "unknown_cell")
    (seq0, seq1) = struct.unpack("<2Q", cols["seq"])
    assert seq0 == st.seq + 1 and seq1 == 0
    x, y, _z = struct.unpack("<3d", cols["origin"][:24])
    assert abs(x - (o.x + 0.1)) < 0.05 and abs(y - o.y) < 0.05
    assert all(math.isnan(v) for v in struct.unpack("<3d", cols["origin"][24:]))
    f0, f1 = struct.unpack("<2I", cols["flags"])
    assert f0 & 1 and f1 == 0
    assert cols["transition_state"][1] == 255 and cols["transition_state"][0] in range(6)
    assert struct.unpack("<2I", cols["cell"])[0] == st.position.cell_id
    assert len(cols["collide_ids"]) == 8 * sum(struct.unpack("<2I", cols["collide_count"]))
    for name, size, width in (("orientation", 8, 4), ("contact_plane", 8, 4), ("collision_normal", 8, 3),
                              ("sliding_normal", 8, 3), ("frames_stationary_fall", 1, 1), ("contact_plane_cell", 4, 1)):
        assert len(cols[name]) == 2 * size * width, name


def test_columnar_publication(service: ServiceProcess, client: Client, ten: list[int]) -> None:
    got: dict[str, list[Any]] = {"columns": [], "states": []}
    lock = threading.Lock()
    s = raw_session(service.endpoint)
    try:
        def keep(name: str) -> Any:
            def on(sample: zenoh.Sample) -> None:
                with lock:
                    got[name].append(msgpack.unpackb(sample.payload.to_bytes(), raw=False))
            return on

        subs = [s.declare_subscriber(f"{P}/state_columns", keep("columns")),
                s.declare_subscriber(f"{P}/states", keep("states"))]
        ids = list(ten)
        ids[3] = 0xDEADBEEF
        off = np.tile([0.1, 0.0, 0.0], (10, 1))

        def published() -> bool:
            client.move_batch(ids, offsets=off, publish="columns")
            return wait_until(lambda: bool(got["columns"]), timeout=0.3)

        assert wait_until(published, timeout=10.0), "no columnar publication"
        with lock:
            msg = got["columns"][-1]
        keep_ids = [m for m in ids if m != 0xDEADBEEF]
        assert msg["n"] == 9 and list(struct.unpack("<9Q", msg["columns"]["id"])) == keep_ids
        assert len(msg["columns"]["origin"]) == 9 * 24
        flags = struct.unpack("<9I", msg["columns"]["flags"])
        assert all(f & 1 for f in flags)
        # "batch" keeps P/states' shape: a list of State maps
        r = client.move_batch(ids, offsets=off, publish="batch")
        assert wait_until(lambda: bool(got["states"]), timeout=5.0)
        with lock:
            states_msg = got["states"][-1]
            assert all("columns" not in m for m in got["states"])
        assert [st["id"] for st in states_msg["states"]] == keep_ids
        assert [st["seq"] for st in states_msg["states"]] == [int(r.seq[k]) for k in range(10) if k != 3]
        for sub in subs:
            sub.undeclare()
    finally:
        s.close()


def test_push_columns_moves_and_reports_errors(service: ServiceProcess, client: Client, ten: list[int]) -> None:
    errors: list[tuple[int | None, Any]] = []
    sub = client.subscribe_errors(lambda mid, e: errors.append((mid, e)))
    try:
        before = _snapshot(client, ten)
        lb = client.landblock_of(ten[0])
        off = [0.1, 0.0, 0.0] * 10
        off[5 * 3 + 1] = math.inf
        payload = msgpack.packb({"v": 1, "kind": "offset", "columns": {
            "id": struct.pack("<10Q", *ten), "offset": struct.pack("<30d", *off)}}, use_bin_type=True)

        def arrived() -> bool:
            return any(mid == ten[5] for mid, _ in errors)

        sent = 0
        while sent < 20 and not arrived():  # the error subscription may need a moment to be known
            client.session.put(client.keys.push(lb), payload)
            sent += 1
            wait_until(arrived, timeout=0.5)
        assert arrived()
        mid, err = next((m, e) for m, e in errors if m == ten[5])
        assert (err.kind, err.path) == ("non_finite", "columns.offset[5][1]")
        after = _snapshot(client, ten)
        assert after[5] == before[5]
        assert all(after[k][0] == before[k][0] + sent for k in range(10) if k != 5)
    finally:
        sub.close()


def test_health_lists_the_column_form_and_the_queries(client: Client) -> None:
    (h,) = client.health()
    assert h.get("move_forms") == ["move", "moves", "columns"]
    assert h.get("queries") == ["sight", "ray", "ground", "place", "path", "random_point"]


def test_client_refuses_wrong_shapes_before_sending(client: Client) -> None:
    with pytest.raises(ValueError, match="offset"):
        client.move_batch([1, 2], offsets=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="exactly one"):
        client.move_batch([1], offsets=np.zeros((1, 3)), motions=np.zeros((1, 3)), dt=0.1)
    with pytest.raises(ValueError, match="dt"):
        client.move_batch([1], motions=np.zeros((1, 3)))
    with pytest.raises(ValueError, match="velocity"):
        client.move_batch([1], motions=np.zeros((1, 3)), dt=0.1, velocities=np.zeros((1, 3)))


def test_async_move_batch_equals_what_the_service_holds(client: Client, service: ServiceProcess,
                                                         ten: list[int]) -> None:
    import asyncio

    from clients import AsyncClient

    async def go() -> BatchResults:
        async with AsyncClient([service.endpoint], timeout=20.0) as ac:
            return await ac.move_batch(ten, offsets=np.tile([0.0, 0.15, 0.0], (10, 1)))

    r = asyncio.run(go())
    assert r.errors == {} and r.resolved.all()
    for k, mid in enumerate(ten):
        st = client.get(mid)[0]
        o = st.position.frame.origin
        assert int(r.seq[k]) == st.seq and _vec(r.origin[k]) == _vec((o.x, o.y, o.z))


def test_each_publishes_per_mover_and_push_envelope_errors_go_to_errors_key(
        service: ServiceProcess, client: Client, ten: list[int]) -> None:
    states: list[Any] = []
    errors: list[tuple[int | None, Any]] = []
    subs = [client.subscribe(states.append, ten[0]), client.subscribe_errors(lambda m, e: errors.append((m, e)))]
    try:
        def published() -> bool:
            client.move_batch(ten[:2], offsets=np.zeros((2, 3)))  # publish "each" by default
            return wait_until(lambda: bool(states), timeout=0.3)

        assert wait_until(published, timeout=10.0)
        assert states[-1].id == ten[0] and states[-1].seq == client.get(ten[0])[0].seq
        lb = client.landblock_of(ten[0])
        bad = msgpack.packb({"v": 1, "kind": "offset", "columns": {"id": struct.pack("<Q", ten[0]),
                                                                    "offset": [0.1, 0.0, 0.0]}}, use_bin_type=True)
        before = client.get(ten[0])[0].seq
        client.session.put(client.keys.push(lb), bad)
        assert wait_until(lambda: any(m is None for m, _ in errors), timeout=5.0)
        err = next(e for m, e in errors if m is None)
        assert (err.kind, err.path) == ("wrong_type", "columns.offset")
        assert client.get(ten[0])[0].seq == before
    finally:
        for s in subs:
            s.close()


def test_reply_flags_are_the_engine_rows_status_and_transient_bits() -> None:
    # the column path writes a reply's flags as a row's status | (transient bits << 16), with no table
    # between them: that holds only while the wire's bits (protocol.md's table, checked above) are the
    # engine's, and the client's transient-state bits are 0x1, 0x2, ... 0x40 in the State's name order
    from engine.world.rows import TRANSIENT_MASK, Status
    from engine.world.transient import NAMED_BITS

    wire = {name: getattr(Flag, name) for name in vars(Flag) if name.isupper() and name != "TRANSIENT_SHIFT"}
    assert wire == {name: getattr(Status, name) for name in vars(Status) if name.isupper()}
    assert [name for name, _bit in NAMED_BITS] == list(TRANSIENT_FLAGS)
    assert [bit for _name, bit in NAMED_BITS] == [1 << k for k in range(len(TRANSIENT_FLAGS))]
    assert TRANSIENT_MASK == (1 << len(TRANSIENT_FLAGS)) - 1
