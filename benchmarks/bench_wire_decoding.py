"""Wire decoding: the service's move readers (msgspec Structs filled from the map msgpack.unpackb gave,
service/protocol/move_structs.py) against the same Structs decoded straight from the bytes
(benchmarks/wire_msgspec.py), on the same payloads, from the bytes to the values the service runs, in this
process.

Times the map form (one move; a batch of 100; the batch with one bad move) and the column form (100 moves,
kinds offset and to; the service reads it from the map with numpy, service/protocol/column_request.py), as
the median µs per payload of many interleaved repetitions; and for a list of bad payloads, the kind and path
docs/protocol.md promises, what the service gives, what msgspec says of the bytes and what that maps to.
The home-grown generator's move reader, which this section first weighed msgspec against, is gone.
"""

from __future__ import annotations

import math
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import msgpack
import numpy as np

from .common import log

__all__ = ["Case", "BAD_CASES", "single_payload", "batch_payload", "column_payload", "current_outcome", "run", "section"]

CELL = 0xA9B40021  # an outdoor cell of landblock A9B4
MOVES = 100


def _pack(obj: Any) -> bytes:
    return bytes(msgpack.packb(obj, use_bin_type=True))


def _move(i: int) -> dict[str, Any]:
    """The batch's i-th move: offsets, targets with cell and orientation, and physics steps in turn."""
    x = 0.25 + 0.01 * i
    if i % 3 == 0:
        m: dict[str, Any] = {"id": 1000 + i, "offset": [x, -0.5, 0.0]}
        if i % 6 == 0:
            m["velocity"] = [1.5, 0.0, 0.0]
    elif i % 3 == 1:
        a = 0.05 * i
        m = {"id": 1000 + i, "to": {"cell": CELL, "origin": [96.0 + x, 96.0, 12.5],
                                    "orientation": [math.cos(a / 2), 0.0, 0.0, math.sin(a / 2)]}}
    else:
        m = {"id": 1000 + i, "motion": [0.0, 4.0 * x, 0.0], "dt": 1 / 30}
    if i % 4 == 0:
        m["tag"] = i
    return m


def single_payload() -> bytes:
    return _pack({"v": 1, "move": {"id": 7, "offset": [1.0, 0.0, 0.0]}})


def batch_payload(n: int = MOVES, bad_at: int | None = None) -> bytes:
    moves = [_move(i) for i in range(n)]
    if bad_at is not None:  # a NaN, and no other fault (with several, the two sides may name another first)
        moves[bad_at] = {"id": 1000 + bad_at, "offset": [0.0, 0.0, math.nan]}
    return _pack({"v": 1, "moves": moves})


def column_payload(n: int = MOVES, kind: str = "offset", columns: dict[str, Any] | None = None) -> bytes:
    ids = np.arange(1000, 1000 + n, dtype="<u8")
    if kind == "offset":
        cols = {"id": ids.tobytes(), "offset": np.tile([0.25, -0.5, 0.0], (n, 1)).astype("<f8").tobytes()}
    else:
        a = 0.05 * np.arange(n)
        q = np.stack([np.cos(a / 2), 0 * a, 0 * a, np.sin(a / 2)], axis=1)
        cols = {"id": ids.tobytes(), "to_cell": np.full(n, CELL, dtype="<u4").tobytes(),
                "to_origin": np.tile([96.5, 96.0, 12.5], (n, 1)).astype("<f8").tobytes(),
                "to_orientation": q.astype("<f8").tobytes()}
    cols.update(columns or {})
    return _pack({"v": 1, "kind": kind, "columns": cols})


# -- bad payloads ---------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Case:
    """A payload and what docs/protocol.md says of it: `expected` (kind, path) of its first error (path
    None: the request as a whole), or None where it is accepted. `form`: map, columns or register."""

    name: str
    payload: bytes
    expected: tuple[str, str | None] | None
    form: str = "map"


def _moves(*moves: Any, **extra: Any) -> bytes:
    return _pack({"v": 1, "moves": list(moves), **extra})


_OK = {"id": 1, "offset": [1.0, 0.0, 0.0]}
_NAN_AT_3 = [_OK, _OK, _OK, {"id": 4, "to": {"origin": [1.0, 2.0, math.nan]}}]
_REGISTER = {"v": 1, "mover": {"spheres": [{"center": [0.0, 0.0, 0.5], "radius": 0.5}]},
             "position": {"cell": CELL, "origin": [10.0, 10.0, 0.0]}}

BAD_CASES: tuple[Case, ...] = (
    Case("NaN in a target's origin", _moves(*_NAN_AT_3), ("non_finite", "moves[3].to.origin[2]")),
    Case("infinity in an offset", _moves({"id": 1, "offset": [math.inf, 0.0, 0.0]}), ("non_finite", "moves[0].offset[0]")),
    Case("real beyond float32", _moves({"id": 1, "offset": [1e39, 0.0, 0.0]}), ("bad_value", "moves[0].offset[0]")),
    Case("id a string (wrong type)", _moves({"id": "7", "offset": [1.0, 0.0, 0.0]}), ("wrong_type", "moves[0].id")),
    Case("boolean for a real", _moves({"id": 1, "offset": [1.0, True, 0.0]}), ("wrong_type", "moves[0].offset[1]")),
    Case("move not a map", _moves(5), ("wrong_type", "moves[0]")),
    Case("id missing", _moves({"offset": [1.0, 0.0, 0.0]}), ("missing_field", "moves[0].id")),
    Case("id nil", _moves({"id": None, "offset": [1.0, 0.0, 0.0]}), ("missing_field", "moves[0].id")),
    Case("unknown field (ignored)", _moves({"id": 1, "offset": [1.0, 0.0, 0.0], "colour": "red"}), None),
    Case("non-unit quaternion", _moves({"id": 1, "to": {"origin": [1.0, 0.0, 0.0], "orientation": [1.0, 1.0, 0.0, 0.0]}}),
         ("bad_value", "moves[0].to.orientation")),
    Case("both to and offset", _moves({"id": 1, "to": {"origin": [1.0, 0.0, 0.0]}, "offset": [1.0, 0.0, 0.0]}),
         ("bad_value", "moves[0]")),
    Case("none of to, offset, motion", _moves({"id": 1}), ("missing_field", "moves[0]")),
    Case("vector of 2 numbers", _moves({"id": 1, "offset": [1.0, 0.0]}), ("bad_value", "moves[0].offset")),
    Case("negative id", _moves({"id": -1, "offset": [1.0, 0.0, 0.0]}), ("bad_value", "moves[0].id")),
    Case("motion without dt", _moves({"id": 1, "motion": [1.0, 0.0, 0.0]}), ("missing_field", "moves[0].dt")),
    Case("dt out of range", _moves({"id": 1, "motion": [1.0, 0.0, 0.0], "dt": 3.0}), ("bad_value", "moves[0].dt")),
    Case("motion beyond the engine's limit", _moves({"id": 1, "motion": [1000.0, 0.0, 0.0], "dt": 0.1}),
         ("bad_value", "moves[0].motion[0]")),
    Case("velocity with motion", _moves({"id": 1, "motion": [1.0, 0.0, 0.0], "dt": 0.1, "velocity": [1.0, 0.0, 0.0]}),
         ("bad_value", "moves[0].velocity")),
    Case("tag of 300 characters", _moves({"id": 1, "offset": [1.0, 0.0, 0.0], "tag": "x" * 300}),
         ("too_large", "moves[0].tag")),
    Case("batch of 4097 moves", _moves(*[_OK] * 4097), ("too_large", "moves")),
    Case("unknown publish", _moves(_OK, publish="all"), ("bad_value", "publish")),
    Case("version 2", _pack({"v": 2, "moves": [_OK]}), ("unsupported_version", "v")),
    Case("not msgpack", b"\xc1", ("malformed", None)),
    Case("msgpack but not a map", _pack([1, 2]), ("malformed", None)),
    Case("register with id 0", _pack({**_REGISTER, "id": 0}), ("bad_value", "id"), "register"),
    Case("column not bin", column_payload(4, columns={"offset": [0.0] * 12}), ("wrong_type", "columns.offset"), "columns"),
    Case("required column missing", _pack({"v": 1, "kind": "to", "columns": {"id": b"\0" * 8}}),
         ("missing_field", "columns.to_origin"), "columns"),
    Case("unknown kind", _pack({"v": 1, "kind": "jump", "columns": {"id": b"\0" * 8}}), ("bad_value", "kind"), "columns"),
    Case("NaN in a column", column_payload(8, columns={"offset": np.array([[0.0] * 3] * 7 + [[math.nan, 0, 0]],
                                                                          dtype="<f8").tobytes()}),
         ("non_finite", "columns.offset[7][0]"), "columns"),
)


# -- the service's side ---------------------------------------------------------------------------------
def current_single(payload: bytes) -> Any:
    """What the service's node does with `{"move": ...}`: the envelope, then parse_single_move."""
    from service.protocol.requests import decode_envelope, parse_single_move

    return parse_single_move(decode_envelope(payload))[0]


def current_batch(payload: bytes) -> Any:
    from service.protocol.requests import decode_envelope, parse_moves

    return parse_moves(decode_envelope(payload))


def current_columns(payload: bytes) -> Any:
    from service.protocol.column_request import parse_column_request
    from service.protocol.requests import decode_envelope

    return parse_column_request(decode_envelope(payload))


def _first_error(batch_or_columns: Any) -> tuple[str, str | None] | None:
    from service.protocol.requests import ItemError

    bad = getattr(batch_or_columns, "bad", None)
    if bad is not None:
        return (bad[min(bad)].kind, bad[min(bad)].path) if bad else None
    for item in batch_or_columns.items:
        if isinstance(item, ItemError):
            return item.error.kind, item.error.path
    return None


def current_outcome(case: Case) -> tuple[str, str | None] | None:
    """The service's (kind, path) for a payload: its first error, or None when accepted."""
    from service.protocol.errors import ProtocolError
    from service.protocol.requests import decode_envelope, parse_register

    try:
        if case.form == "register":
            parse_register(decode_envelope(case.payload))
            return None
        return _first_error((current_columns if case.form == "columns" else current_batch)(case.payload))
    except ProtocolError as e:
        return e.kind, e.path


def candidate_outcome(case: Case) -> tuple[tuple[str, str | None] | None, str]:
    """msgspec's side: the mapped (kind, path), and msgspec's own message (or the post-pass's)."""
    import msgspec

    from service.protocol.errors import ProtocolError

    from . import wire_msgspec as w

    struct: type[Any] = {"map": w.MoveRequestS, "columns": w.ColumnRequestS, "register": w.RegisterIdS}[case.form]
    decoder = msgspec.msgpack.Decoder(struct)
    try:
        decoder.decode(case.payload)
        said = "accepted by the Structs"
    except (msgspec.ValidationError, msgspec.DecodeError) as e:
        said = str(e)
    try:
        if case.form == "register":
            w.decode_register_id(case.payload)
            return None, said
        if case.form == "columns":
            return _first_error(w.decode_columns(case.payload)), said
        for item in w.decode_batch(case.payload):
            if isinstance(item, ProtocolError):
                return (item.kind, item.path), said if said != "accepted by the Structs" else f"post-pass: {item.message}"
        return None, said
    except ProtocolError as e:
        return (e.kind, e.path), said if said != "accepted by the Structs" else f"post-pass: {e.message}"


# -- timing -----------------------------------------------------------------------------------------------
def _interleaved(fns: dict[str, Callable[[bytes], Any]], payload: bytes, reps: int) -> dict[str, float]:
    """Median µs per call of each function on `payload`, the functions taking turns rep after rep (so a
    slow spell of the machine falls on all of them); each sample is a loop of ~0.2 ms."""
    inner: dict[str, int] = {}
    for name, fn in fns.items():
        t0 = time.perf_counter_ns()
        for _ in range(20):
            fn(payload)
        inner[name] = max(1, int(200_000 / max(1.0, (time.perf_counter_ns() - t0) / 20)))
    samples: dict[str, list[float]] = {name: [] for name in fns}
    for _ in range(reps):
        for name, fn in fns.items():
            k = inner[name]
            t0 = time.perf_counter_ns()
            for _ in range(k):
                fn(payload)
            samples[name].append((time.perf_counter_ns() - t0) / k / 1000.0)
    return {name: statistics.median(s) for name, s in samples.items()}


def _candidate_fns() -> dict[str, dict[str, Callable[[bytes], Any]]]:
    from . import wire_msgspec as w

    return {"single": {"msgspec": w.decode_single, "msgspec_structs": w.decode_structs},
            "batch": {"msgspec": w.decode_batch, "msgspec_typed": w.decode_batch_typed, "msgspec_structs": w.decode_structs},
            "columns": {"msgspec": w.decode_columns}}


def _same_result(form: str, payload: bytes) -> bool:
    """Whether msgspec's side builds what the service builds from `payload` (checked before timing)."""
    from service.protocol.requests import ItemError

    from . import wire_msgspec as w

    if form == "single":
        return bool(w.decode_single(payload) == current_single(payload))
    if form == "batch":
        mine = current_batch(payload).items
        for other in (w.decode_batch(payload), w.decode_batch_typed(payload)):
            for a, b in zip(mine, other, strict=True):
                if isinstance(a, ItemError):
                    if (a.error.kind, a.error.path) != (getattr(b, "kind", None), getattr(b, "path", None)):
                        return False
                elif a != b:
                    return False
        return True
    c, d = current_columns(payload), w.decode_columns(payload)
    return _columns_equal(c, d)


def _columns_equal(a: Any, b: Any) -> bool:
    return (a.kind, a.n, a.publish, sorted(a.arrays), sorted(a.bad)) == (b.kind, b.n, b.publish, sorted(b.arrays), sorted(b.bad)) \
        and all(np.array_equal(a.arrays[k], b.arrays[k]) for k in a.arrays)


def run(quick: bool) -> dict[str, Any]:
    import msgspec

    reps = 41 if quick else 301
    payloads = [
        ("single", "one move `{\"v\":1,\"move\":{...}}` (offset)", single_payload()),
        ("batch", f"a batch of {MOVES} moves (offset, to with cell and orientation, motion + dt; some tags)",
         batch_payload()),
        ("batch", "the same batch, move 51 with a NaN (fails alone)", batch_payload(bad_at=51)),
        ("columns", f"a column request of {MOVES} moves, kind offset", column_payload()),
        ("columns", f"a column request of {MOVES} moves, kind to (cell, origin, orientation)", column_payload(kind="to")),
    ]
    current = {"single": current_single, "batch": current_batch, "columns": current_columns}
    candidates = _candidate_fns()
    rows = []
    for form, label, payload in payloads:
        fns: dict[str, Callable[[bytes], Any]] = {"service": current[form]}
        fns["msgpack_unpackb"] = lambda p: msgpack.unpackb(p, raw=False, strict_map_key=False)
        for name, fn in candidates.get(form, {}).items():
            try:  # the Structs alone refuse the batch with a bad move: nothing to time there
                fn(payload)
            except Exception:  # noqa: BLE001,S112 - msgspec.ValidationError
                continue
            fns[name] = fn
        same = _same_result(form, payload)
        log(f"wire decoding: {label} ({len(payload)} bytes)")
        us = _interleaved(fns, payload, reps)
        rows.append({"form": form, "payload": label, "bytes": len(payload), "items": 1 if form == "single" else MOVES,
                     "us": us, "same_result": same})
    errors = []
    for case in BAD_CASES:
        row: dict[str, Any] = {"name": case.name, "form": case.form, "expected": case.expected,
                               "service": current_outcome(case)}
        row["msgspec"], row["msgspec_said"] = candidate_outcome(case)
        errors.append(row)
    out: dict[str, Any] = {"reps": reps, "rows": rows, "errors": errors, "msgspec_version": msgspec.__version__}
    out["msgpack_version"] = ".".join(str(x) for x in msgpack.version)
    return out


# -- the report's section -----------------------------------------------------------------------------------
def section(data: dict[str, Any], meta: str) -> list[str]:
    """The report's section (benchmarks/report.py); `meta` its line on how it was measured."""
    out = ["## Wire decoding: moves read with msgspec, from the map and from the bytes", "", meta, ""]
    if "skipped" in data:  # a stored run of before msgspec was a dependency
        return out + [f"Not compared: {data['skipped']}.", ""]
    out += [METHOD.format(reps=data["reps"], msgspec=data.get("msgspec_version", "?"),
                          msgpack=data.get("msgpack_version", "?")), "",
            "µs per payload, median of the repetitions; \"service\" is `decode_envelope` and then "
            "`parse_single_move` / `parse_moves` / `parse_column_request`, as service/bus/node.py runs them; "
            "\"from the bytes\" decodes each move of a batch on its own (`list[msgspec.Raw]`, then a "
            "`Decoder(MoveS)` per item) so that a bad move fails alone, as the protocol asks; \"whole batch "
            "typed\" decodes `list[MoveS]` at once and falls back to the former when a move is refused; \"Structs "
            "alone\" is msgspec's decoding without the post-pass.", "",
            "| payload | bytes | service (msgpack.unpackb, then msgspec.convert + post-pass) | of which msgpack.unpackb | "
            "msgspec from the bytes + post-pass | from the bytes, whole batch typed | Structs alone | "
            "service / best from the bytes | same values |",
            "|---|---|---|---|---|---|---|---|---|"]
    for r in data["rows"]:
        us = r["us"]
        typed = f"{us['msgspec_typed']:.1f}" if "msgspec_typed" in us else "-"
        alone = f"{us['msgspec_structs']:.1f}" if "msgspec_structs" in us else "-"
        best = min(us["msgspec"], us.get("msgspec_typed", math.inf))
        per = f" ({us['service'] / r['items']:.2f} / {best / r['items']:.2f} per move)" if r["items"] > 1 else ""
        out.append(f"| {r['payload']} | {r['bytes']} | {us['service']:.1f} | {us['msgpack_unpackb']:.1f} | "
                   f"{us['msgspec']:.1f} | {typed} | {alone} | {us['service'] / best:.2f}x{per} | "
                   f"{'yes' if r['same_result'] else 'NO'} |")
    out += ["", "Bad payloads: the first error docs/protocol.md promises, the service's, msgspec's own message on "
            "the bytes and what it maps to (service/protocol/move_structs.py `protocol_error`, reading the "
            "message's text).", "",
            "| payload | protocol.md | service | msgspec says | mapped | mapped = protocol |", "|---|---|---|---|---|---|"]
    for e in data["errors"]:
        expected = tuple(e["expected"]) if e["expected"] else None
        got = tuple(e["msgspec"]) if e.get("msgspec") else None
        said = e.get("msgspec_said", "").replace("|", "\\|").replace("`", "'")
        out.append(f"| {e['name']} | {_ko(expected)} | {_ko(e['service'])} | {said} | {_ko(got)} | "
                   f"{'yes' if got == expected else 'NO'} |")
    return out + ["", *finding(data), ""]


METHOD = ("Both sides in this process, from the same msgpack bytes to the values the service runs (`MoveItem`s "
          "with the engine's Vec3 and Quat, a `ColumnRequest` of numpy arrays), checked equal before timing (last "
          "column). The service's moves are msgspec {msgspec} Structs (service/protocol/move_structs.py, `MoveS`) "
          "filled by `msgspec.convert` from the map msgpack.unpackb gave: `Meta` states a real's bounds "
          "±3.4028235e38 (which NaN and ±infinity fail too), uint32 bounds, id ≥ 0, a tag's 256 characters, "
          "vector and quaternion lengths (fixed tuples); a post-pass in Python, timed with it, does the rest "
          "(exactly one of to/offset/motion, `dt` with `motion` and no `velocity` then, the unit quaternion, "
          "the engine's motion limit, the 64-bit upper bounds) and builds the engine's values. \"From the bytes\" "
          "(benchmarks/wire_msgspec.py) decodes the same Structs, in typed envelopes, straight from the payload "
          "with the same post-pass; for columns, the envelope typed with each `bin` a memoryview (no copy), then "
          "parse_column_request's checks (the same numpy code). msgpack {msgpack}; {reps} interleaved "
          "repetitions, each a loop of ~0.2 ms.")


def finding(data: dict[str, Any]) -> list[str]:
    """What this run found: whether every error kind and path is kept, and what reading the bytes instead
    of the map would save."""
    rows = data["rows"]
    ratio = {r["payload"]: r["us"]["service"] / min(r["us"]["msgspec"], r["us"].get("msgspec_typed", math.inf))
             for r in rows}
    maps = [ratio[r["payload"]] for r in rows if r["form"] != "columns"]
    cols = [ratio[r["payload"]] for r in rows if r["form"] == "columns"]

    def kept(side: str) -> bool:
        return all((tuple(e[side]) if e.get(side) else None) == (tuple(e["expected"]) if e["expected"] else None)
                   for e in data["errors"])

    same = all(r["same_result"] for r in rows)
    figures = (f"Decoding from the bytes took 1/{min(maps):.2f} to 1/{max(maps):.2f} of the service's time on the map "
               f"form and 1/{min(cols):.2f} to 1/{max(cols):.2f} on the column form. "
               f"The service gave every bad payload {'the' if kept('service') else 'NOT the'} kind and path "
               f"docs/protocol.md promises; msgspec's errors on the bytes mapped to "
               f"{'them' if kept('msgspec') else 'NOT all of them'}"
               f"{'' if same else '; some good payloads did NOT decode to the same values'}.")
    return ["**Finding.** " + figures, "",
            "**What is left.** service/bus/node.py decodes every request with msgpack.unpackb (`decode_envelope`) "
            "before it knows the operation, so the service fills its Structs from that map (`msgspec.convert`) "
            "and pays the generic decoding first (the table's \"of which msgpack.unpackb\"). Handing a move "
            "request's bytes to msgspec instead would save the difference between the service's column and the "
            "best \"from the bytes\" one; the column form gains the most there, since its `bin`s then decode "
            "as memoryviews. Either way most of a map-form move's time is the Python post-pass that builds the "
            "engine's values."]


def _ko(x: Any) -> str:
    if x is None:
        return "accepted"
    kind, path = x
    return f"`{kind}` at `{path}`" if path else f"`{kind}` (whole request)"
