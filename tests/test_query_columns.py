"""The column form of the spatial queries (docs/protocol.md, "Query columns").

- the doc's tables, flag bits and worked example against the one declaration
  in service/query_columns.py;
- the request checks without a service: whole-request errors name the
  column, item errors name the column, the item and the component;
- against a service on the demo scene: every op's column answers equal the
  map form's answers to the same queries bit for bit, a bad item fails alone,
  Health announces the form; `Client.sights` pairs name their own target
  and viewer as the map form's items do.
"""

from __future__ import annotations

import math
import re
import struct
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import msgpack
import numpy as np
import pytest

from clients import Client, SightQuery
from clients.demo_world import global_to_cell
from clients.errors import ServiceError
from engine.geometry import Position, Vec3
from service.errors import ProtocolError
from service.query_columns import BLOCKER_CODES, PLACEMENT_CODES, QUERY_COLUMNS, QUERY_FORMS, parse_query_columns
from service.wire import ErrorKind
from service_support import ServiceProcess, demo_world, human

DOC = Path(__file__).resolve().parent.parent / "docs" / "protocol.md"
WORLD = demo_world()
A9B4 = 0xA9B4


def _section(heading: str) -> str:
    text = DOC.read_text(encoding="utf-8")
    start = text.index(f"\n{heading}\n")
    nxt = re.search(r"\n#{2,4} ", text[start + len(heading) + 2:])
    return text[start:start + len(heading) + 2 + (nxt.start() if nxt else len(text))]


def _tables(section: str) -> list[list[list[str]]]:
    """Every table of a section: its rows (header and rule skipped), cells stripped of backticks."""
    out: list[list[list[str]]] = []
    rows: list[str] = []
    for line in section.splitlines() + [""]:
        if line.startswith("|"):
            rows.append(line)
        elif rows:
            out.append([[c.strip().strip("`") for c in r.strip("|").split("|")] for r in rows[2:]])
            rows = []
    return out


# -- the document against the declaration -------------------------------------------------------
@pytest.mark.parametrize("op", list(QUERY_COLUMNS))
def test_doc_tables_and_flag_bits_match_the_declaration(op: str) -> None:
    spec = QUERY_COLUMNS[op]
    section = _section(f"#### {op.capitalize()} columns")
    request, reply = _tables(section)
    assert [r[0] for r in request] == [c.name for c in spec.request]
    for r, col in zip(request, spec.request):
        assert (r[1], int(r[2]), r[3]) == (col.dtype, col.width, "required" if op in col.required else "optional")
    assert [r[0] for r in reply] == [c.name for c in spec.reply]
    for r, col in zip(reply, spec.reply):
        assert (r[1], int(r[2]), r[3]) == (col.dtype, col.width, col.missing), col.name
    bits = " ".join(section[section.index("`flags` bits"):].split())
    named = re.findall(r"(\d+) `([^`]+)`", bits)
    assert [(int(k), name) for k, name in named] == list(enumerate(spec.flags))


def test_doc_codes_and_health_forms_match_the_declaration() -> None:
    text = " ".join(_section("### Query columns").split())
    for code, kind in enumerate(BLOCKER_CODES):
        assert f"{code} `{kind}`" in text
    place = " ".join(_section("#### Place columns").split())
    for code, name in enumerate(PLACEMENT_CODES):
        assert f"{code} `{name}`" in place
    health = _section("### Health")
    assert f"`{list(QUERY_FORMS)}`".replace("'", '"') in health


def test_doc_worked_example_is_the_request_it_describes() -> None:
    section = _section("#### Ground columns")
    data = bytes.fromhex(" ".join(section.split("```")[1].split()))
    assert int(re.search(r"is these\s+(\d+) bytes", section).group(1)) == len(data)  # type: ignore[union-attr]
    msg = msgpack.unpackb(data, raw=False)
    assert msg == {"v": 1, "columns": {"cell": struct.pack("<I", 0xA9B4000B), "origin": struct.pack("<3d", 40.0, 50.0, 60.0)}}
    req = parse_query_columns("ground", msg, A9B4)
    assert req.n == 1 and req.arrays["cell"].tolist() == [0xA9B4000B] and req.arrays["origin"].tolist() == [[40.0, 50.0, 60.0]]


# -- request checks without a service -----------------------------------------------------------
def _segments(n: int, **extra: bytes) -> dict[str, Any]:
    cols = {"from_cell": struct.pack(f"<{n}I", *[0xA9B4000B] * n), "from_origin": struct.pack(f"<{3 * n}d", *[40.0, 50.0, 60.0] * n),
            "to_cell": struct.pack(f"<{n}I", *[0xA9B4000B] * n), "to_origin": struct.pack(f"<{3 * n}d", *[41.0, 50.0, 60.0] * n)}
    cols.update(extra)
    return {"v": 1, "columns": cols}


def _refused(op: str, msg: dict[str, Any]) -> ProtocolError:
    with pytest.raises(ProtocolError) as ei:
        parse_query_columns(op, msg, A9B4)
    return ei.value


def test_whole_request_errors_name_the_column() -> None:
    cases = [
        ("sight", _segments(3, to_origin=struct.pack("<6d", *[0.0] * 6)), ErrorKind.BAD_VALUE, "columns.to_origin"),
        ("sight", _segments(3, radius=struct.pack("<3d", 0.1, 0.1, 0.1)[:-4]), ErrorKind.BAD_VALUE, "columns.radius"),
        ("sight", _segments(3, radius=[0.1, 0.1, 0.1]), ErrorKind.WRONG_TYPE, "columns.radius"),  # type: ignore[arg-type]
        ("sight", _segments(3, colour=b"\x00"), ErrorKind.BAD_VALUE, "columns.colour"),
        ("ray", _segments(3), ErrorKind.MISSING_FIELD, "columns.radius"),
        ("sight", _segments(4097), ErrorKind.TOO_LARGE, "columns.from_cell"),
        ("ground", {"v": 1, "columns": [1, 2]}, ErrorKind.WRONG_TYPE, "columns"),
    ]
    for op, msg, kind, path in cases:
        err = _refused(op, msg)
        assert (err.kind, err.path) == (kind, path), (op, path, err)
        assert path in err.message
    both = {**_segments(1), "sight": {}}
    assert _refused("sight", both).kind == ErrorKind.BAD_VALUE


def test_item_errors_name_column_index_and_component_and_spare_the_others() -> None:
    origins = [40.0, 50.0, 60.0] * 6
    origins[1 * 3 + 2] = math.nan
    origins[2 * 3 + 0] = 1e39
    cells = [0xA9B4000B] * 6
    cells[3] = 0xA9B5000B
    msg = _segments(6, from_origin=struct.pack("<18d", *origins), from_cell=struct.pack("<6I", *cells),
                    radius=struct.pack("<6d", 0.1, 0.1, 0.1, 0.1, -0.5, 0.0))
    req = parse_query_columns("sight", msg, A9B4)
    got = {i: (e.kind, e.path) for i, e in req.bad.items()}
    assert got == {1: (ErrorKind.NON_FINITE, "columns.from_origin[1][2]"), 2: (ErrorKind.BAD_VALUE, "columns.from_origin[2][0]"),
                   3: (ErrorKind.WRONG_LANDBLOCK, "columns.from_cell[3]"), 4: (ErrorKind.BAD_VALUE, "columns.radius[4]")}
    assert req.bad[3].extra == {"landblock": 0xA9B5}
    # a ray's radius must be positive; 0 is a sight's default
    ray = parse_query_columns("ray", _segments(2, radius=struct.pack("<2d", 0.2, 0.0)), A9B4)
    assert [(i, e.path) for i, e in ray.bad.items()] == [(1, "columns.radius[1]")]
    q = struct.pack("<8d", 1.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0)
    place = parse_query_columns("place", {"v": 1, "columns": {"cell": struct.pack("<2I", 0xA9B4000B, 0xA9B4000B),
                                                               "origin": struct.pack("<6d", *[1.0] * 6), "orientation": q}}, A9B4)
    assert [(i, e.path) for i, e in place.bad.items()] == [(1, "columns.orientation[1]")]


# -- against a service --------------------------------------------------------------------------
def above(gx: float, gy: float, dz: float) -> Position:
    cell, x, y = global_to_cell(gx, gy)
    return Position.at(cell, Vec3(x, y, WORLD.terrain_height(cell, x, y) + dz))


@pytest.fixture(scope="module")
def service() -> Iterator[ServiceProcess]:
    with ServiceProcess() as svc:
        yield svc


@pytest.fixture()
def client(service: ServiceProcess) -> Iterator[Client]:
    with Client([service.endpoint], timeout=10.0) as c:
        c.wait_ready()
        yield c


def _columns_of(positions: list[Position]) -> tuple[np.ndarray[Any, Any], np.ndarray[Any, Any]]:
    return (np.array([p.cell_id for p in positions], dtype=np.uint32),
            np.array([p.frame.origin.as_tuple() for p in positions], dtype=np.float64))


def _bits(v: Any) -> Any:
    """A value as exact text (floats by repr; None and NaN kept apart)."""
    return repr(v.tolist() if isinstance(v, np.ndarray) else v)


def _vec(row: Any, given: bool) -> Any:
    return _bits(row) if given else None


GRID = [(40.0 + 13.0 * i, 50.0 + 7.0 * j) for i in range(4) for j in range(3)]


def test_sight_columns_equal_the_single_form_bit_for_bit(client: Client) -> None:
    eyes = [above(gx, gy, 1.6) for gx, gy in GRID]
    # looking at points above, on and under the land 30 m away: some clear, some stopped by the terrain
    targets = [above(gx + 30.0, gy + 10.0, dz) for (gx, gy), dz in zip(GRID, [5.0, -3.0, 1.6, -10.0] * 3)]
    fc, fo = _columns_of(eyes)
    tc, to = _columns_of(targets)
    cols = client.sight_columns(fc, fo, tc, to)
    assert not cols.errors and cols.flag("resolved").all()
    assert cols.flag("clear").any() and not cols.flag("clear").all()
    for i, (a, b) in enumerate(zip(eyes, targets)):
        one = client.sight(a, b)
        assert bool(cols.flag("clear")[i]) == one.clear
        stop_given = bool(cols.flag("stop given")[i])
        assert stop_given == (one.stop is not None)
        if one.stop is not None:
            assert _bits(cols["stop"][i]) == _bits(np.array(one.stop.frame.origin.as_tuple()))
            assert int(cols["cell"][i]) == one.cell == one.stop.cell_id
        normal = None if one.normal is None else _bits(np.array(one.normal.as_tuple()))
        assert _vec(cols["normal"][i], bool(cols.flag("normal given")[i])) == normal
        assert cols.blocker_kind(i) == (None if one.blocker is None else one.blocker.kind)


def test_ray_columns_equal_the_batch_form_bit_for_bit(client: Client) -> None:
    starts = [above(gx, gy, 3.0) for gx, gy in GRID]
    ends = [above(gx + 20.0, gy, -3.0 if k % 2 else 4.0) for k, (gx, gy) in enumerate(GRID)]
    fc, fo = _columns_of(starts)
    tc, to = _columns_of(ends)
    cols = client.ray_columns(fc, fo, tc, to, 0.1)
    batch = client.rays(list(zip(starts, ends)), 0.1)
    assert not cols.errors
    for i, hit in enumerate(batch):
        assert not isinstance(hit, ServiceError)
        assert bool(cols.flag("hit")[i]) == hit.hit
        assert _bits(cols["position"][i]) == _bits(np.array(hit.position.frame.origin.as_tuple()))
        assert int(cols["cell"][i]) == hit.cell and _bits(cols["distance"][i]) == _bits(np.float64(hit.distance))
        normal = None if hit.normal is None else _bits(np.array(hit.normal.as_tuple()))
        assert _vec(cols["normal"][i], bool(cols.flag("normal given")[i])) == normal
        assert cols.blocker_kind(i) == (None if hit.blocker is None else hit.blocker.kind)
        assert bool(cols.flag("blocker_id given")[i]) == (hit.blocker is not None and hit.blocker.object_id is not None)


def test_ground_columns_equal_the_single_form_and_a_bad_item_fails_alone(client: Client) -> None:
    points = [above(gx, gy, 2.0) for gx, gy in GRID]
    cells, origins = _columns_of(points)
    origins[4, 1] = math.nan
    cells[7] = (A9B4 << 16) | 0x0999  # no such indoor cell: the engine refuses it
    cols = client.ground_columns(cells, origins)
    assert set(cols.errors) == {4, 7}
    e4, e7 = cols.errors[4], cols.errors[7]
    assert isinstance(e4, ServiceError) and (e4.kind, e4.path) == (ErrorKind.NON_FINITE, "columns.origin[4][1]")
    assert isinstance(e7, ServiceError) and e7.kind == ErrorKind.UNKNOWN_CELL and e7.path == "columns.cell[7]"
    assert not cols.flag("resolved")[[4, 7]].any() and np.isnan(cols["z"][[4, 7]]).all()
    for i, p in enumerate(points):
        if i in (4, 7):
            continue
        g = client.ground(p)
        assert g is not None and cols.flag("found")[i] and bool(cols.flag("walkable")[i]) == g.walkable
        n = g.plane.normal
        assert _bits(cols["z"][i]) == _bits(np.float64(g.z))
        assert _bits(cols["plane"][i]) == _bits(np.array([n.x, n.y, n.z, g.plane.d]))
        assert int(cols["cell"][i]) == g.cell and _bits(cols["water_depth"][i]) == _bits(np.float64(g.water_depth))


def test_place_columns_equal_the_batch_form_bit_for_bit(client: Client) -> None:
    spots = [above(gx, gy, 0.5) for gx, gy in GRID[:6]]
    cells, origins = _columns_of(spots)
    cols = client.place_columns(human(), cells, origins)
    batch = client.places([(human(), p) for p in spots])
    assert not cols.errors
    for i, placed in enumerate(batch):
        assert not isinstance(placed, ServiceError) and placed.position is not None
        assert cols.placement_result(i) == placed.placement_result == "OK" and cols.flag("ok")[i]
        assert int(cols["cell"][i]) == placed.position.cell_id
        assert _bits(cols["origin"][i]) == _bits(np.array(placed.position.frame.origin.as_tuple()))
        assert _bits(cols["orientation"][i]) == _bits(np.array(placed.position.frame.orientation.as_tuple()))
        for flag in ("contact", "on_walkable", "water_contact"):
            assert bool(cols.flag(flag)[i]) == getattr(placed, flag)
        if placed.contact_plane is not None:
            n = placed.contact_plane.normal
            assert _bits(cols["contact_plane"][i]) == _bits(np.array([n.x, n.y, n.z, placed.contact_plane.d]))
            assert int(cols["contact_plane_cell"][i]) == placed.contact_plane_cell


def test_targets_and_viewers_by_column_and_by_pair(client: Client) -> None:
    st = client.register(human(), above(100.0, 120.0, 0.0))
    try:
        m = st.position.frame.origin
        eye = Position.at(st.position.cell_id, Vec3(m.x, m.y, m.z + 1.6))
        # from inside the mover's body to a point 3 m away and back through it
        out = Position.at(st.position.cell_id, Vec3(m.x + 3.0, m.y, m.z + 1.35))
        pairs = [SightQuery(eye, out, viewer=st.id), SightQuery(out, eye, target=st.id), SightQuery(out, eye), (out, eye)]
        answers = client.sights(pairs)
        singles = [client.sight(eye, out, viewer=st.id), client.sight(out, eye, target=st.id), client.sight(out, eye),
                   client.sight(out, eye)]
        assert [repr(a) for a in answers] == [repr(s) for s in singles]
        assert answers[1].clear and not answers[2].clear  # type: ignore[union-attr]  # the target ends the sweep as arrived
        fc, fo = _columns_of([eye, out, out, out])
        tc, to = _columns_of([out, eye, eye, eye])
        cols = client.sight_columns(fc, fo, tc, to, targets=np.array([0, st.id, 0, 0xDEAD], dtype=np.uint64),
                                    viewers=np.array([st.id, 0, 0, 0], dtype=np.uint64))
        assert cols.flag("clear")[:3].tolist() == [s.clear for s in singles[:3]]
        assert int(cols["blocker_id"][2]) == st.id and cols.flag("blocker_id given")[2]
        e = cols.errors[3]
        assert isinstance(e, ServiceError) and (e.kind, e.path) == (ErrorKind.UNKNOWN_MOVER, "columns.target[3]")
    finally:
        client.remove(st.id)


def test_health_announces_the_column_form(client: Client) -> None:
    (h,) = client.health()
    assert h.get("query_forms") == ["single", "batch", "columns"]


def test_client_refuses_wrong_shapes_before_sending(client: Client) -> None:
    with pytest.raises(ValueError, match="from_origin"):
        client.sight_columns([0xA9B4000B], np.zeros((2, 3)), [0xA9B4000B], np.zeros((1, 3)))
    with pytest.raises(ValueError, match="radius"):
        client.ray_columns([0xA9B4000B], np.zeros((1, 3)), [0xA9B4000B], np.zeros((1, 3)), [0.1, 0.2])
