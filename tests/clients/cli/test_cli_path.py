"""`acphys path`, run as a user would (a subprocess) against a service on the shared flat scene.

What it should print comes from the geometry (a straight path across open flat ground is as long as the
distance) and from `acphys path --help`'s own words: exit status 0 when the service answered, found or
not; 1 when the query failed; 2 for a usage error; never a traceback.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from pathlib import Path

import pytest

from clients import Client
from engine import Position, Vec3
from service.protocol.codec import encode_mover_spec
from support.service_harness import ServiceProcess, human
from support.shared_data import SCENES, require_shared
from test_cli import acphys

require_shared()

FLAT_Z = 112.5  # the flat scene's ground (height byte 50)
START = ["A9B4000A", "30", "30", str(FLAT_Z)]  # cell 0A holds x 24..48, y 24..48
GOAL = ["A9B40038", "150", "170", str(FLAT_Z)]  # cell 38 holds x 144..168, y 168..192
STRAIGHT = math.hypot(120.0, 140.0)


@pytest.fixture(scope="module")
def service() -> Iterator[ServiceProcess]:
    with ServiceProcess(SCENES / "flat.json") as svc:
        yield svc


def test_a_path_prints_found_its_length_and_each_waypoint(service: ServiceProcess) -> None:
    r = acphys("path", "--from", *START, "--to", *GOAL, "--connect", service.endpoint)
    assert r.returncode == 0, r.stderr
    rows = {line.split(None, 1)[0]: line.split(None, 1)[1] for line in r.stdout.splitlines() if line.strip()}
    assert rows["found"] == "yes"
    assert float(rows["length"].split()[0]) == pytest.approx(STRAIGHT, rel=0.02)
    count = int(rows["waypoints"])
    assert count >= 2 and all(str(i) in rows for i in range(count))
    assert rows["0"].startswith("cell A9B4000A") and rows[str(count - 1)].startswith("cell A9B40038")


def test_json_is_the_answer_map(service: ServiceProcess) -> None:
    r = acphys("path", "--from", *START, "--to", *GOAL, "--connect", service.endpoint, "--json")
    assert r.returncode == 0, r.stderr
    a = json.loads(r.stdout)
    assert set(a) == {"found", "waypoints", "length", "expanded", "reason", "detail"}
    assert a["found"] is True and a["reason"] is None and a["detail"] == ""
    assert a["length"] == pytest.approx(STRAIGHT, rel=0.02)
    last = a["waypoints"][-1]
    assert last["cell"] == 0xA9B40038
    assert math.hypot(last["origin"][0] - 150.0, last["origin"][1] - 170.0) <= 0.25


def test_not_found_is_an_answer_exit_0_with_the_reason(service: ServiceProcess) -> None:
    r = acphys("path", "--from", *START, "--to", "B0B00001", "10", "10", str(FLAT_Z), "--connect", service.endpoint)
    assert r.returncode == 0, r.stderr
    assert "found  no" in r.stdout and "not_loaded" in r.stdout
    r = acphys("path", "--from", *START, "--to", *GOAL, "--max-distance", "100", "--connect", service.endpoint, "--json")
    assert r.returncode == 0, r.stderr
    a = json.loads(r.stdout)
    assert a["found"] is False and a["reason"] == "unreachable" and a["waypoints"] == []


def test_a_registered_mover_and_a_mover_file(service: ServiceProcess, tmp_path: Path) -> None:
    with Client([service.endpoint], timeout=30.0) as c:
        start = Position.at(0xA9B4000A, Vec3(30.0, 30.0, FLAT_Z))
        ground = c.ground(start.with_origin(Vec3(30.0, 30.0, FLAT_Z + 1.0)))
        assert ground is not None
        st = c.register(human(contact=True), start, contact_plane=ground.plane)  # standing on the ground
        try:
            r = acphys("path", "--id", f"{st.id:X}", "--to", *GOAL, "--connect", service.endpoint, "--json")
            assert r.returncode == 0, r.stderr
            a = json.loads(r.stdout)
            assert a["found"] is True and a["waypoints"][0]["origin"] == pytest.approx([30.0, 30.0, FLAT_Z], abs=1e-9)
        finally:
            c.remove(st.id)
    # a walker 3 m wide (one sphere of 1.5 m): the open field is open for it too
    spec = tmp_path / "big.json"
    big = encode_mover_spec(human())
    big["spheres"] = [{"center": [0.0, 0.0, 1.5], "radius": 1.5}]
    spec.write_text(json.dumps(big), encoding="utf-8")
    r = acphys("path", "--from", *START, "--to", *GOAL, "--mover", str(spec), "--connect", service.endpoint, "--json")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["found"] is True


def test_failures_say_what_and_exit_1(service: ServiceProcess) -> None:
    r = acphys("path", "--id", "7777777", "--landblock", "A9B4", "--to", *GOAL, "--connect", service.endpoint)
    assert r.returncode == 1 and "unknown_mover" in r.stderr and "Traceback" not in r.stderr
    assert r.stderr.startswith("acphys path:")
    r = acphys("path", "--from", *START, "--to", *GOAL, "--budget", "100001", "--connect", service.endpoint)
    assert r.returncode == 1 and "bad_value" in r.stderr and "budget" in r.stderr, r.stderr


@pytest.mark.parametrize(("argv", "expected"), [
    (["--from", *START, "--id", "7", "--to", *GOAL], "not allowed with argument"),
    (["--to", *GOAL], "one of the arguments --from --id is required"),
    (["--from", *START], "the following arguments are required: --to"),
    (["--from", *START, "--to", *GOAL, "--budget", "0"], "at least 1"),
    (["--from", *START, "--to", *GOAL, "--max-distance", "-3"], "more than 0 m"),
    (["--id", "7", "--to", *GOAL, "--mover", "x.json"], "an --id mover has its own"),
    (["--from", *START, "--to", *GOAL, "--mover", "/nonexistent/walker.json"], "/nonexistent/walker.json"),
], ids=["from and id", "neither", "no goal", "budget 0", "negative distance", "id and mover", "no mover file"])
def test_usage_errors_exit_2(argv: list[str], expected: str, tmp_path: Path) -> None:
    r = acphys("path", *argv, "--connect", "tcp/127.0.0.1:9")  # nothing is sent: it never connects
    assert r.returncode == 2, (r.stdout, r.stderr)
    assert expected in r.stderr and "Traceback" not in r.stderr


def test_a_mover_file_that_is_not_a_moverspec_is_a_usage_error(tmp_path: Path) -> None:
    bad = tmp_path / "walker.json"
    bad.write_text(json.dumps({"spheres": [{"center": [0, 0, 1], "radius": -1}]}), encoding="utf-8")
    r = acphys("path", "--from", *START, "--to", *GOAL, "--mover", str(bad), "--connect", "tcp/127.0.0.1:9")
    assert r.returncode == 2 and str(bad) in r.stderr and "radius" in r.stderr, r.stderr
    bad.write_text("{not json", encoding="utf-8")
    r = acphys("path", "--from", *START, "--to", *GOAL, "--mover", str(bad), "--connect", "tcp/127.0.0.1:9")
    assert r.returncode == 2 and "not JSON" in r.stderr, r.stderr


def test_help_says_the_exit_status() -> None:
    r = acphys("path", "--help")
    assert r.returncode == 0
    assert "Exit status: 0 when the service answered, a path found or not" in " ".join(r.stdout.split())
