"""The column form of the spatial queries (docs/protocol.md, "Query columns").

- the doc's tables, flag bits and worked example against the one declaration
  in service/protocol/query_columns.py;
- the request checks without a service: whole-request errors name the
  column, item errors name the column, the item and the component.

Against a service (the column answers equal the map form's bit for bit):
tests/service/test_service_queries.py.
"""

from __future__ import annotations

import math
import re
import struct
from pathlib import Path
from typing import Any

import msgpack
import pytest

from service.protocol.errors import ProtocolError
from service.protocol import (
    BLOCKER_CODES,
    PLACEMENT_CODES,
    QUERY_COLUMNS,
    QUERY_FORMS,
    QUERY_OPS,
    REASON_CODES,
    REQUEST_OPS,
)
from service.protocol.query_columns import parse_query_columns
from service.protocol.wire import ErrorKind

DOC = Path(__file__).resolve().parents[3] / "docs" / "protocol.md"
A9B4 = 0xA9B4


def _section(heading: str) -> str:
    text = DOC.read_text(encoding="utf-8")
    if f"\n{heading}\n" not in text and heading.startswith("#### "):  # a section of its own (### Path columns)
        heading = heading[1:]
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
    section = _section(f"#### {op.replace('_', ' ').capitalize()} columns")
    request, reply, *ragged = _tables(section)
    assert [r[0] for r in request] == [c.name for c in spec.request]
    assert [[r[0], r[1], int(r[2])] for r in (ragged[0] if ragged else [])] == [[c.name, c.dtype, c.width] for c in spec.ragged]
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
    path = " ".join(_section("### Path columns").split())
    for code, name in enumerate(REASON_CODES):
        assert f"{code} `{name}`" in path
    health = _section("### Health")
    assert f"`{list(QUERY_FORMS)}`".replace("'", '"') in health
    assert f"`{list(QUERY_OPS)}`".replace("'", '"') in health
    stats = " ".join(_section("### Stats").split())
    assert ", ".join(f"`{op}`" for op in REQUEST_OPS) + " is listed" in stats


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
    place = parse_query_columns("place", {"v": 1, "mover": {"spheres": [{"center": [0, 0, 0.5], "radius": 0.5}]},
                                          "columns": {"cell": struct.pack("<2I", 0xA9B4000B, 0xA9B4000B),
                                                               "origin": struct.pack("<6d", *[1.0] * 6), "orientation": q}}, A9B4)
    assert [(i, e.path) for i, e in place.bad.items()] == [(1, "columns.orientation[1]")]


def test_a_radius_outside_a_millimetre_to_ten_metres_fails_its_item() -> None:
    # 0.001 m is five times the transition's distance tolerance (0.2 mm): smaller spheres are lost in it
    radii = [0.001, 0.0009, 1e-200, 5e-324, 10.0, 10.5, 0.0]
    for op, bad in (("ray", {1, 2, 3, 5, 6}), ("sight", {1, 2, 3, 5})):  # a sight's 0 is its default
        req = parse_query_columns(op, _segments(len(radii), radius=struct.pack(f"<{len(radii)}d", *radii)), A9B4)
        assert {i: (e.kind, e.path) for i, e in req.bad.items()} == \
            {i: (ErrorKind.BAD_VALUE, f"columns.radius[{i}]") for i in bad}, op


@pytest.mark.parametrize("op", ["sight", "ray"])
def test_nil_single_or_batch_field_beside_columns_is_as_good_as_absent(op: str) -> None:
    many = {"sight": "sights", "ray": "rays"}[op]
    msg = _segments(1, radius=struct.pack("<d", 0.1))
    for nil in ({op: None}, {many: None}):
        req = parse_query_columns(op, {**msg, **nil}, A9B4)
        assert req.n == 1 and not req.bad
