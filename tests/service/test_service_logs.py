"""The service's logs: INFO at start, stop and each state write; DEBUG one line per request (key, items,
result, time); WARNING for every error answered, rate-limited per kind; `--log-format json`, one object
per line (service/logs.py, service/bus/request_log.py)."""

from __future__ import annotations

import json
import logging
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import msgpack

from clients import Client
from clients.demo.world import global_to_cell
from engine.geometry import Position, Vec3
from service.logs import JsonFormatter
from service.bus.request_log import ErrorLog
from support.service_harness import ROOT, ServiceProcess, child_env, demo_world, human, raw_query, raw_session, wait_until


class _Lines(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.DEBUG)
        self.records: list[logging.LogRecord] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.records.append(record)


def _error_log(lines: int = 3, window: float = 1.0) -> tuple[ErrorLog, _Lines, list[float]]:
    logger = logging.getLogger("test.acphys.errors")
    logger.handlers.clear()
    logger.propagate = False
    logger.setLevel(logging.DEBUG)
    sink = _Lines()
    logger.addHandler(sink)
    now = [100.0]
    return ErrorLog(logger, lines=lines, window=window, clock=lambda: now[0]), sink, now


def _fields(r: logging.LogRecord) -> dict[str, Any]:
    return dict(getattr(r, "fields", {}))


def test_error_lines_are_limited_per_kind_and_the_rest_counted() -> None:
    errors, sink, now = _error_log(lines=3)
    for k in range(50):  # a flood within one second
        errors.error("bad_value", "move", "acphys/lb/A9B4/move", f"bad {k}")
    errors.error("busy", "move", "acphys/lb/A9B4/move", "queue full")  # another kind has its own allowance
    assert [r.getMessage() for r in sink.records] == [
        "move answered bad_value on acphys/lb/A9B4/move: bad 0",
        "move answered bad_value on acphys/lb/A9B4/move: bad 1",
        "move answered bad_value on acphys/lb/A9B4/move: bad 2",
        "move answered busy on acphys/lb/A9B4/move: queue full"]
    assert all(r.levelno == logging.WARNING for r in sink.records)
    errors.flush()  # the window is not over: nothing yet
    assert len(sink.records) == 4
    now[0] += 1.0
    errors.flush()
    assert sink.records[-1].getMessage() == "47 more bad_value error(s) answered in the last 1.0 s, not logged one by one"
    assert _fields(sink.records[-1]) == {"event": "errors_not_logged", "kind": "bad_value", "count": 47, "seconds": 1.0}
    # a new window logs again, and an error after a full window sums it up first
    for k in range(5):
        errors.error("bad_value", "move", "k", f"again {k}")
    now[0] += 2.5
    errors.error("bad_value", "move", "k", "later")
    tail = [r.getMessage() for r in sink.records[5:]]
    assert tail == ["move answered bad_value on k: again 0", "move answered bad_value on k: again 1",
                    "move answered bad_value on k: again 2",
                    "2 more bad_value error(s) answered in the last 2.5 s, not logged one by one",
                    "move answered bad_value on k: later"]


def test_at_shutdown_every_count_held_back_is_said() -> None:
    errors, sink, _now = _error_log(lines=1)
    for _ in range(4):
        errors.error("unknown_mover", "get", "acphys/lb/*/get", "no such mover")
    errors.flush(everything=True)
    assert [_fields(r).get("count") for r in sink.records] == [None, 3]


def test_json_lines_carry_the_fields_and_the_traceback() -> None:
    fmt = JsonFormatter()
    rec = logging.LogRecord("acphys.requests", logging.DEBUG, __file__, 1, "move %s: %s", ("k", "ok"), None)
    rec.fields = {"op": "move", "key": "k", "items": 1, "result": "ok", "ms": 0.25}
    line = fmt.format(rec)
    assert "\n" not in line
    obj = json.loads(line)
    assert obj["level"] == "DEBUG" and obj["logger"] == "acphys.requests" and obj["message"] == "move k: ok"
    assert (obj["op"], obj["key"], obj["items"], obj["result"], obj["ms"]) == ("move", "k", 1, "ok", 0.25)
    assert obj["time"].endswith("Z") and obj["pid"] > 0
    try:
        raise ValueError("boom\nsecond line")
    except ValueError:
        rec = logging.LogRecord("acphys.service", logging.ERROR, __file__, 1, "failed", (), sys.exc_info())
    line = fmt.format(rec)
    assert "\n" not in line and "ValueError: boom" in json.loads(line)["exception"]


def _json_lines(output: list[str]) -> list[dict[str, Any]]:
    return [json.loads(ln) for ln in output if ln.startswith("{")]


def test_a_service_logs_requests_errors_state_and_stop_as_json(tmp_path: Path) -> None:
    state = tmp_path / "movers.state"
    svc = ServiceProcess(extra=["--log-level", "DEBUG", "--log-format", "json", "--state", str(state),
                                "--state-interval", "0"])
    with svc:
        with Client([svc.endpoint], timeout=10.0) as c:
            c.wait_ready()
            cell, x, y = global_to_cell(40.0, 40.0)
            z = demo_world().terrain_height(cell, x, y) + 2.0
            st = c.register(human(), Position.at(cell, Vec3(x, y, z)), mover_id=0x4242)
            c.move(st.id, offset=(0.5, 0.0, 0.0))
        session = raw_session(svc.endpoint)
        try:
            batch = {"v": 1, "moves": [{"id": 0x4242, "offset": [0.1, 0.0, 0.0]}, {"id": 0x999, "offset": [0.1, 0.0, 0.0]}]}
            ok, reply = raw_query(session, "acphys/lb/A9B4/move", msgpack.packb(batch))
            assert ok and reply["results"][1]["error"]["kind"] == "unknown_mover"
            ok, reply = raw_query(session, "acphys/lb/A9B4/move", msgpack.packb({"v": 1, "move": {"id": 0x777}}))
            assert not ok and reply["error"]["kind"] == "missing_field"
            # a query batch answers each item: an indoor cell the landblock lacks is an error answered too
            grounds = {"v": 1, "grounds": [{"position": {"cell": cell, "origin": [x, y, z]}},
                                           {"position": {"cell": 0xA9B40999, "origin": [1.0, 1.0, 1.0]}}]}
            ok, reply = raw_query(session, "acphys/lb/A9B4/ground", msgpack.packb(grounds))
            assert ok and reply["grounds"][1]["error"]["kind"] == "unknown_cell"
        finally:
            session.close()
        assert svc.stop(signal.SIGTERM) == 0
    lines = [ln for ln in svc.output if ln.strip()]
    # every line but the ready line is one JSON object
    assert [ln for ln in lines if not ln.startswith("{")] == [ln for ln in lines if "acphys service ready" in ln]
    logs = _json_lines(lines)
    requests = [o for o in logs if o.get("event") == "request"]
    moves = [o for o in requests if o["op"] == "move"]
    assert {"key": "acphys/lb/A9B4/move", "items": 1, "result": "ok"}.items() <= moves[0].items()
    assert moves[0]["level"] == "DEBUG" and moves[0]["ms"] >= 0.0
    assert {"items": 2, "result": "ok"}.items() <= moves[1].items()  # the batch, one item of it refused
    assert {"items": 1, "result": "missing_field"}.items() <= moves[2].items()
    assert [o["result"] for o in requests if o["op"] == "register"] == ["ok"]
    errors = [o for o in logs if o.get("event") == "error"]
    assert [(o["level"], o["op"], o["kind"]) for o in errors] == [("WARNING", "move", "unknown_mover"),
                                                                 ("WARNING", "move", "missing_field"),
                                                                 ("WARNING", "ground", "unknown_cell")]
    assert errors[2]["item"] == 1 and errors[2]["key"] == "acphys/lb/A9B4/ground"
    assert errors[0]["id"] == 0x999 and errors[0]["item"] == 1 and "999" in errors[0]["error"]
    assert errors[1]["key"] == "acphys/lb/A9B4/move"
    infos = [o["message"] for o in logs if o["level"] == "INFO"]
    assert any(m.startswith("started: instance ") for m in infos), infos
    assert any(m.startswith(f"state written: 1 mover(s) to {state}") for m in infos), infos
    assert infos[-1] == "stopped"


def test_a_flood_of_bad_requests_writes_a_bounded_number_of_lines() -> None:
    svc = ServiceProcess(extra=["--log-level", "INFO"])
    sent = 400
    with svc:
        session = raw_session(svc.endpoint)
        try:
            began = time.monotonic()
            for k in range(sent):
                ok, _ = raw_query(session, "acphys/lb/A9B4/get", msgpack.packb({"v": 1, "id": 0x5000 + k}))
                assert not ok
            elapsed = time.monotonic() - began
        finally:
            session.close()
        assert svc.stop(signal.SIGTERM) == 0
    shown = [ln for ln in svc.output if "get answered unknown_mover on acphys/lb/A9B4/get" in ln]
    held = [ln for ln in svc.output if "more unknown_mover error(s) answered" in ln]
    counted = sum(int(ln.split(" more unknown_mover")[0].rsplit(" ", 1)[-1]) for ln in held)
    assert len(shown) + counted == sent  # each error written, or counted in a summary
    windows = elapsed / 1.0 + 2  # a window opens at an error and lasts 1 s
    assert len(shown) <= 10 * windows and len(held) <= windows, (len(shown), len(held), elapsed)


def test_workers_log_in_the_same_format() -> None:
    svc = ServiceProcess(extra=["--workers", "2", "--log-level", "DEBUG", "--log-format", "json"])
    with svc:
        with Client([svc.endpoint], timeout=10.0) as c:
            (health,) = c.wait_ready()
            east = health["worker_processes"][1]["pid"]
            cell, x, y = global_to_cell(250.0, 40.0)
            c.register(human(), Position.at(cell, Vec3(x, y, demo_world().terrain_height(cell, x, y) + 2.0)),
                       mover_id=0x4343)
        assert wait_until(lambda: any(o.get("op") == "register" and o["pid"] == east
                                      for o in _json_lines(list(svc.output))), timeout=10.0)
        assert svc.stop(signal.SIGTERM) == 0
    lines = [ln for ln in svc.output if ln.strip()]
    assert [ln for ln in lines if not ln.startswith("{")] == [ln for ln in lines if "acphys service ready" in ln]
    logs = _json_lines(lines)
    assert any(o["message"].startswith("started: instance ") and "2 workers" in o["message"] for o in logs)
    assert any(o.get("event") == "request" and o["op"] == "health" and o["pid"] != east for o in logs)  # the face


def test_serve_help_shows_every_default() -> None:
    r = subprocess.run([sys.executable, "-m", "service", "--help"], cwd=ROOT, env=child_env(), capture_output=True,
                       text=True, timeout=60)
    text = " ".join(r.stdout.split())
    assert "--handover-timeout S seconds to wait" in text and "(default 2.0)" in text
    assert "--log-format {text,json}" in text and "(default text)" in text
