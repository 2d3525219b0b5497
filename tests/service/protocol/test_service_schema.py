"""docs/protocol.md's field tables against the messages' declarations (service/protocol/messages.py), and the
declarations' readers and writers against each other.

The document is the contract independent clients are written from; the declaration drives the service's
reading, checking and writing and the client library's. Each table row must name a declared field with
the declared type (and whether it is required); each declared field must have its row.
"""

from __future__ import annotations

import re
from pathlib import Path

import msgpack
import pytest

from engine.geometry import Plane, Position, Quat, Vec3
from engine.world.types import CylSphereSpec, MoverSpec, SphereSpec
from service.protocol.errors import ProtocolError
from service.protocol.messages import (
    ERROR,
    HANDOVER,
    HEALTH,
    ID_REQUEST,
    LANDBLOCK_LIST,
    MOVE,
    MOVE_REQUEST,
    MOVER_SPEC,
    PLANE,
    POSITION,
    REGISTER,
    STATE,
    STATS,
    UPDATE,
    HandoverRequest,
    RegisterRequest,
)
from service.protocol.schema import Map
from service.protocol.wire import ErrorKind

DOC = (Path(__file__).resolve().parents[3] / "docs" / "protocol.md").read_text(encoding="utf-8")


def _section(heading: str) -> str:
    start = DOC.index(f"\n{heading}\n")
    nxt = re.search(r"\n#{1,4} ", DOC[start + len(heading) + 2:])
    return DOC[start:start + len(heading) + 2 + (nxt.start() if nxt else len(DOC))]


def _rows(section: str, first: int = 0) -> list[list[str]]:
    """The `first`-th table of a section: its rows (header and rule left out), cells without backticks."""
    tables: list[list[str]] = []
    current: list[str] = []
    for line in section.splitlines() + [""]:
        if line.startswith("|"):
            current.append(line)
        elif current:
            tables.append(current[2:])
            current = []
    # a `|` inside a cell is written `\|`
    return [[c.replace("\\|", "|").replace("`", "").strip() for c in re.split(r"(?<!\\)\|", r.strip().strip("|"))]
            for r in tables[first]]


def _names(cell: str) -> list[str]:
    """`a`, `b` in one row: both fields."""
    return [n.strip() for n in cell.split(",")]


def _plain(text: str) -> str:
    return text.replace("`", "")


def _check_table(msg: Map, rows: list[list[str]], *, suffixes: bool, skip: tuple[str, ...] = ()) -> None:
    """Every row names declared fields of `msg` with their type; every declared field (but `skip`) has a row.
    `suffixes`: the type cell ends with ", required" / ", optional" as the field is required or not (a cell
    without one: optional); else the type cell is the type alone."""
    seen: set[str] = set()
    for row in rows:
        for name in _names(row[0]):
            assert name in msg.by_name, f"{msg.name}: the doc's {name!r} is not declared"
            f = msg.by_name[name]
            seen.add(name)
            cell = row[1]
            if not cell:  # "as in Health": described elsewhere
                continue
            if suffixes:
                required = cell.endswith(", required")
                cell = re.sub(r", (required|optional)$", "", cell)
                assert required == (name in msg.required_names), f"{msg.name}.{name}: required in doc {required}"
            assert cell == _plain(f.doc_type), f"{msg.name}.{name}: doc {cell!r}, declared {f.doc_type!r}"
    declared = {f.name for f in msg.fields} - set(skip)
    assert declared <= seen, f"{msg.name}: declared but not in the doc: {sorted(declared - seen)}"


def _inline(text: str) -> dict[str, tuple[str, bool]]:
    """`{"v": 1, "id": uint64, "path"?: string, ...}` as {name: (type, optional)} (without v and ...)."""
    body = text.strip()[1:-1]
    parts, depth, cur = [], 0, ""
    for ch in body:  # split at the commas outside brackets
        depth += ch in "[{" and 1 or ch in "]}" and -1 or 0
        if ch == "," and depth == 0:
            parts.append(cur)
            cur = ""
        else:
            cur += ch
    parts.append(cur)
    out = {}
    for p in parts:
        m = re.fullmatch(r'\s*"(\w+)"(\?)?:\s*(.+?)\s*', p)
        if m is None or m.group(1) == "v":
            continue
        out[m.group(1)] = (m.group(3), bool(m.group(2)))
    return out


def _check_inline(msg: Map, text: str) -> None:
    fields = _inline(text)
    assert set(fields) == {f.name for f in msg.fields}, msg.name
    for name, (doc_type, optional) in fields.items():
        f = msg.by_name[name]
        assert doc_type == _plain(f.doc_type), f"{msg.name}.{name}: doc {doc_type!r}, declared {f.doc_type!r}"
        assert optional == (name not in msg.required_names), f"{msg.name}.{name}"


# -- the tables -----------------------------------------------------------------------------------------
def test_position_table() -> None:
    _check_table(POSITION, _rows(_section("### Position")), suffixes=False)


def test_plane_fields() -> None:
    assert _inline(re.search(r'`(\{"normal".*?\})`', _section("### Plane")).group(1)).keys() == PLANE.by_name.keys()  # type: ignore[union-attr]


def test_mover_spec_table_with_defaults() -> None:
    rows = _rows(_section("### MoverSpec"))
    _check_table(MOVER_SPEC, [[r[0], r[1]] for r in rows], suffixes=False)
    for name, _type, default, _meaning in rows:
        f = MOVER_SPEC.by_name[name]
        if f.required:
            assert default.startswith("required"), name
        else:
            d = f.default
            want = "true" if d is True else "false" if d is False else "nil" if d is None else "[]" if d == [] else repr(d)
            assert default == want, f"MoverSpec.{name}: doc default {default!r}, declared {f.default!r}"


def test_state_table() -> None:
    _check_table(STATE, _rows(_section("### State")), suffixes=False)


def test_move_tables() -> None:
    section = _section("### Move request")
    _check_table(MOVE_REQUEST, _rows(section, 0), suffixes=False, skip=("move", "moves"))
    _check_table(MOVE, _rows(section, 1), suffixes=True)


def test_register_table_and_the_forms_built_on_it() -> None:
    _check_table(REGISTER, _rows(_section("### Register")), suffixes=True)
    # "a Register map with `id` required, plus `seq` (uint64 ...) and `from` (string ...)"
    handover = " ".join(_section("### Hand-over (between instances)").split())
    assert "a [Register](#register) map with `id` required" in handover
    for name in ("seq", "from", "state"):
        doc_type = re.search(rf"`{name}` \((\w+)", handover).group(1)  # type: ignore[union-attr]
        assert doc_type == HANDOVER.by_name[name].doc_type
    assert {f.name for f in HANDOVER.fields} == {f.name for f in REGISTER.fields} | {"seq", "from", "state"}
    assert HANDOVER.required_names == REGISTER.required_names | {"id", "seq"}


def test_update_remove_get_forms() -> None:
    _check_inline(UPDATE, re.search(r"`(\{\"v\": 1, \"id\".*?\})`", _section("### Update")).group(1))  # type: ignore[union-attr]
    for heading in ("### Remove", "### Get"):
        _check_inline(ID_REQUEST, re.search(r"`(\{\"v\": 1, \"id\".*?\})`", _section(heading)).group(1))  # type: ignore[union-attr]


def test_error_form_and_kinds() -> None:
    section = _section("## Errors")
    form = re.search(r"An Error is `(\{.*?\})`", section).group(1).replace(", ...", "")  # type: ignore[union-attr]
    _check_inline(ERROR, form)
    kinds = [r[0] for r in _rows(section)]
    assert kinds == list(ErrorKind.ALL)
    assert ERROR.by_name["kind"].kind.values == ErrorKind.ALL  # type: ignore[attr-defined]


def test_health_stats_and_list() -> None:
    _check_table(HEALTH, _rows(_section("### Health")), suffixes=False)
    _check_table(STATS, _rows(_section("### Stats")), suffixes=False)
    form = re.search(r"replies\s+`(\{\"v\": 1, \"instance\".*?\})`", _section("### List"), re.S).group(1)  # type: ignore[union-attr]
    fields = _inline(" ".join(form.split()))
    assert set(fields) <= LANDBLOCK_LIST.by_name.keys()
    for name, (doc_type, _opt) in fields.items():
        assert doc_type == LANDBLOCK_LIST.by_name[name].doc_type


# -- one declaration: what is written reads back ------------------------------------------------------
def _spec() -> MoverSpec:
    return MoverSpec(spheres=[SphereSpec((0.0, 0.0, 0.48), 0.48), SphereSpec((0.0, 0.0, 1.35), 0.48)],
                     step_up_height=0.6, state=["Contact", "OnWalkable", "IsPlayer"], creature=True,
                     cyl_spheres=[CylSphereSpec((0.0, 0.0, 0.0), 0.3, 1.2)])


def test_register_written_by_the_client_reads_back() -> None:
    from clients.client import _encode_register

    pos = Position.at(0xA9B40001, Vec3(10.0, 12.0, 50.0), Quat(0.0, 0.0, 0.0, 1.0))
    req = RegisterRequest(7, _spec(), pos, Plane(Vec3(0.0, 0.0, 1.0), -50.0), None, Vec3(1.0, 0.0, 0.0), True)
    wire = msgpack.unpackb(msgpack.packb(_encode_register(req)), raw=False)
    back = REGISTER.read(wire, "")
    assert back.spec == req.spec and back.id == 7 and back.water_contact is True
    assert back.position.cell_id == pos.cell_id and back.position.frame.origin == pos.frame.origin
    assert back.contact_plane_cell == pos.cell_id  # defaults to the position's cell
    assert "contact_plane_cell" not in wire and "id" in wire


def test_handover_written_reads_back() -> None:
    pos = Position.at(0xA9B40001, Vec3(10.0, 12.0, 50.0))
    sent = HandoverRequest(9, 4, _spec(), pos, None, None, None, False, "zid")
    back = HANDOVER.read(msgpack.unpackb(msgpack.packb(HANDOVER.encode_fn()(sent)), raw=False), "")
    assert (back.id, back.seq, back.spec, back.source, back.contact_plane) == (9, 4, sent.spec, "zid", None)
    assert back.state is None  # no State to publish: the field is left out


def test_handover_state_reads_back_and_is_bounded() -> None:
    from service.protocol.messages import MAX_HANDOVER_STATE

    pos = Position.at(0xA9B40001, Vec3(10.0, 12.0, 50.0))
    sent = HandoverRequest(9, 4, _spec(), pos, None, None, None, False, "zid", b"\x81\xa2id\x09")
    wire = msgpack.unpackb(msgpack.packb(HANDOVER.encode_fn()(sent)), raw=False)
    assert HANDOVER.read(wire, "").state == b"\x81\xa2id\x09"
    for bad, kind in (("not bytes", "wrong_type"), (b"x" * (MAX_HANDOVER_STATE + 1), "bad_value")):
        with pytest.raises(ProtocolError) as e:
            HANDOVER.read({**wire, "state": bad}, "")
        assert (e.value.kind, e.value.path) == (kind, "state")


@pytest.mark.parametrize("value,kind,path", [
    ({"id": 0, "mover": {"spheres": [{"center": [0, 0, 0], "radius": 1}]}}, "bad_value", "id"),
    ({"id": 3}, "missing_field", "mover"),
    ({"mover": {"spheres": []}}, "bad_value", "mover.spheres"),
    ({"mover": {"spheres": [{"center": [0, 0, 0], "radius": 0}]}}, "bad_value", "mover.spheres[0].radius"),
    ({"mover": {"spheres": [{"center": [0, 0, 0], "radius": 1}], "state": ["Flying"]}}, "bad_value", "mover.state[0]"),
])
def test_register_errors_name_the_field(value: dict[str, object], kind: str, path: str) -> None:
    with pytest.raises(ProtocolError) as e:
        REGISTER.read(value, "")
    assert (e.value.kind, e.value.path) == (kind, path)


def test_the_key_table_has_a_row_for_every_per_landblock_operation() -> None:
    """"Key expressions": a queryable row `P/lb/XXYY/<op>` for each operation the service serves there, and the
    push key's subscriber row; no row for an operation the service does not have."""
    from service.protocol import LB_OPS

    rows = dict(re.findall(r"^\| `P/lb/XXYY/(\w+)` \| (queryable|subscriber) \|", DOC, flags=re.M))
    assert rows.pop("push") == "subscriber"
    assert rows == {op: "queryable" for op in LB_OPS}
