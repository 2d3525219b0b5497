"""What `acphys` says when something is wrong: a message that diagnoses, exit status 2 (the command line is
wrong) or 1 (the command failed), and never a traceback.

Most commands run in-process (`clients.__main__.main` with an argv, stderr captured); a few run as a user runs
them (a subprocess), for what only a whole process shows. The services are real ones on free loopback
ports: a plain one over the demo world and one run with `--users`.
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Iterator
from pathlib import Path

import pytest

from clients.__main__ import build_parser, main
from clients.cli.parser import walk_parsers
from support.service_harness import ROOT, ServiceProcess, endpoint, free_port
from test_cli import acphys

#: a Python exception's class name (`OutOfRangeError`, `ValueError`, `ZError`), which no user should see
CLASS_NAME = re.compile(r"\b[A-Z][A-Za-z0-9]*(Error|Exception)\b")
#: a source location of Zenoh's build (`.../endpoint.rs:615`)
RUST_PATH = re.compile(r"\.rs:\d+")
USERS = {"alice": "looking-glass-3"}
COMMANDS = [path for path, _ in walk_parsers(build_parser())]


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    """`acphys ARGV` in this process: exit status, stdout, stderr."""
    try:
        status = main(argv)
    except SystemExit as e:  # argparse's way out: --help, --version and usage errors
        status = e.code if isinstance(e.code, int) else 1
    out, err = capsys.readouterr()
    return status, out, err


def assert_clean(err: str) -> None:
    """A message for a user: no traceback, no Python class name, no source path of Zenoh's."""
    assert "Traceback" not in err, err
    assert not CLASS_NAME.search(err), err
    assert not RUST_PATH.search(err), err


# -- every command's help ---------------------------------------------------------------------------------


def test_the_walk_finds_every_command() -> None:
    names = {path[0] for path in COMMANDS if path}
    assert {"serve", "router", "move", "demo", "view", "stats", "inspect", "load-region",
            "ground", "sight", "ray", "place"} <= names
    assert () in COMMANDS  # the program's own


@pytest.mark.parametrize("path", COMMANDS, ids=lambda p: " ".join(p) or "acphys")
def test_every_command_has_help(path: tuple[str, ...], capsys: pytest.CaptureFixture[str]) -> None:
    status, out, err = run([*path, "--help"], capsys)
    assert status == 0, err
    assert out.startswith("usage: acphys" + "".join(f" {w}" for w in path)), out
    assert_clean(out + err)


def test_version_names_the_package_and_the_protocol(capsys: pytest.CaptureFixture[str]) -> None:
    package = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]["version"]
    found = re.search(r'carries \*\*`"v": (\d+)`\*\*, the protocol version', (ROOT / "docs/protocol.md").read_text())
    assert found is not None
    status, out, _ = run(["--version"], capsys)
    assert status == 0
    assert out.startswith(f"acphys {package} (protocol version {found.group(1)}")


# -- usage errors: exit status 2, before anything is sent -------------------------------------------------

POS = ["A9B4000B", "40", "50", "60"]
USAGE_ERRORS: list[tuple[str, list[str], list[str]]] = [
    ("no command", [], ["required: COMMAND"]),
    ("unknown command", ["nosuchcommand"], ["invalid choice: 'nosuchcommand'"]),
    ("ground without Z", ["ground", "A9B4000B", "40", "50"], ["required: Z"]),
    ("place without Y Z", ["place", "A9B4000B", "40"], ["required: Y, Z"]),
    ("ground with a fifth number", ["ground", *POS, "70"], ["unrecognized arguments: 70"]),
    ("sight --to of three", ["sight", "--from", *POS, "--to", *POS[:3]], ["--to: expected 4 arguments"]),
    ("bad hex cell", ["move", "--start", "zz", "20", "20", "60", "--offset", "1", "0", "0"],
     ["--start: 'zz' is not a cell id", "8 hex digits"]),
    ("landblock id for a cell id", ["move", "--start", "A9B4", "20", "20", "60", "--offset", "1", "0", "0"],
     ["'A9B4' is a landblock id, not a cell id", "8 hex digits", "A9B40001"]),
    ("cell id of 6 digits", ["ground", "A9B401", "40", "50", "60"], ["'A9B401' is not a cell id"]),
    ("bad hex mover id", ["move", "--id", "zz", "--offset", "1", "0", "0"], ["--id: 'zz' is not a hex mover id"]),
    ("bad landblock", ["move", "--id", "7", "--landblock", "A9G4", "--offset", "1", "0", "0"],
     ["--landblock: 'A9G4' is not a hex landblock id"]),
    ("bad number", ["move", "--id", "7", "--offset", "1", "x", "0"], ["--offset: 'x' is not a number"]),
    ("too few numbers", ["move", "--id", "7", "--offset", "1", "0"], ["--offset: expected 3 arguments"]),
    ("a number that is not finite", ["ground", "A9B4000B", "40", "nan", "60"], ["'nan' is not a finite number"]),
    ("infinite dt", ["move", "--id", "7", "--motion", "0", "1", "0", "--dt", "inf"], ["--dt: 'inf' is not a finite"]),
    ("--to of two", ["move", "--id", "7", "--to", "1", "2"], ["--to: takes X Y Z or CELL X Y Z"]),
    ("misspelt option", ["move", "--start", "A9B40001", "20", "20", "60", "--ofset", "1", "0", "0"],
     ["unknown option --ofset", "did you mean --offset?"]),
    ("unknown option", ["stats", "--bogus"], ["unknown option --bogus"]),
    ("unknown option before the command", ["--bogus", "stats"], ["unknown option --bogus"]),
    ("connect without a protocol", ["stats", "--connect", "127.0.0.1:7511"],
     ["'127.0.0.1:7511' is not an endpoint", "tcp/127.0.0.1:7447"]),
    ("connect to port 99999", ["stats", "--connect", "tcp/127.0.0.1:99999"],
     ["port '99999' is not a number from 1 to 65535", "tcp/127.0.0.1:7447"]),
    ("connect without a port", ["ray", "--from", *POS, "--to", *POS, "--connect", "tcp/127.0.0.1"], ["has no port"]),
    ("serve listening without a protocol", ["serve", "--listen", "127.0.0.1:7511"],
     ["--listen: '127.0.0.1:7511' is not an endpoint to listen on", "tcp/127.0.0.1:7447"]),
    ("serve on port 99999", ["serve", "--listen", "tcp/127.0.0.1:99999"], ["port '99999' is not a number from 0"]),
    ("router on an unknown protocol", ["router", "--listen", "foo/127.0.0.1:7447"], ["'foo' is not a protocol"]),
    ("router connecting without a port", ["router", "--connect", "tcp/localhost"], ["has no port"]),
    ("a wildcard prefix", ["stats", "--prefix", "a*b"], ["'a*b' is not a key prefix"]),
    ("an empty prefix chunk", ["serve", "--prefix", "a//b"], ["'a//b' is not a key prefix"]),
    ("no wait at all", ["stats", "--timeout", "0"], ["--timeout: '0'", "above 0"]),
    ("view on port 99999", ["view", "--port", "99999"], ["--port: '99999' is not a port"]),
    ("inspect a bad landblock", ["inspect", "/tmp", "zz"], ["'zz' is not a hex landblock id"]),
    ("load-region of one corner", ["load-region", "/tmp", "A9B4"], ["required: TO"]),
]


@pytest.mark.parametrize(("argv", "expected"), [(a, e) for _, a, e in USAGE_ERRORS], ids=[n for n, _, _ in USAGE_ERRORS])
def test_usage_errors_exit_2_and_say_what_is_wrong(argv: list[str], expected: list[str],
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    status, out, err = run(argv, capsys)
    assert status == 2, err
    assert out == ""
    assert_clean(err)
    last = err.strip().splitlines()[-1]
    assert last.startswith("acphys") and "error:" in last, err
    for text in expected:
        assert text in last, last


def test_a_demo_picture_nowhere_is_refused_before_the_walk(capsys: pytest.CaptureFixture[str]) -> None:
    status, out, err = run(["demo", "--embedded", "--out", "/nonexistent-directory/walk.png"], capsys)
    assert status == 2 and out == ""
    assert err.strip() == "acphys demo: --out /nonexistent-directory/walk.png: there is no directory /nonexistent-directory"


def test_a_user_without_a_password_is_a_usage_error(capsys: pytest.CaptureFixture[str],
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("ACPHYS_PASSWORD", raising=False)
    status, _, err = run(["stats", "--user", "alice", "--connect", endpoint(free_port())], capsys)
    assert status == 2
    assert err.strip() == "acphys stats: --user needs a password: --password-file FILE or ACPHYS_PASSWORD"


def test_as_a_user_runs_them(tmp_path: Path) -> None:
    """The installed way in: the same answers from a process of its own."""
    r = acphys("ground", "--help")
    assert r.returncode == 0 and "CELL X Y Z" in r.stdout and r.stderr == ""
    r = acphys("move", "--start", "zz", "1", "2", "3", "--offset", "1", "0", "0")
    assert r.returncode == 2 and "'zz' is not a cell id" in r.stderr
    assert_clean(r.stderr)


# -- failures: exit status 1 --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def service() -> Iterator[ServiceProcess]:
    """The demo world's four landblocks, owned by name; INFO log, which names them."""
    with ServiceProcess(own="A9B4,A9B5,AAB4,AAB5", extra=["--log-level", "INFO"]) as svc:
        yield svc


@pytest.fixture(scope="module")
def accounts(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[ServiceProcess, Path]]:
    """A service run with --users, and the directory of its users file and of password files."""
    folder = tmp_path_factory.mktemp("cli-accounts")
    users = folder / "users.txt"
    users.write_text("".join(f"{u}:{p}\n" for u, p in USERS.items()), encoding="utf-8")
    (folder / "right").write_text(USERS["alice"] + "\n", encoding="utf-8")
    (folder / "wrong").write_text("not-the-password\n", encoding="utf-8")
    with ServiceProcess(extra=["--users", str(users)]) as svc:
        yield svc, folder


def test_nothing_listening_names_the_endpoint_and_prefix(capsys: pytest.CaptureFixture[str]) -> None:
    where = endpoint(free_port())
    status, _, err = run(["stats", "--connect", where, "--timeout", "1"], capsys)
    assert status == 1
    assert_clean(err)
    assert err.startswith("acphys stats: no service instance answered") and err.count("\n") == 1
    assert f"tried {where}, prefix 'acphys'" in err and f"nothing accepts connections at {where}" in err


def test_a_move_with_nothing_listening_says_so_too(capsys: pytest.CaptureFixture[str]) -> None:
    where = endpoint(free_port())
    status, _, err = run(["move", "--start", "A9B40001", "20", "20", "60", "--offset", "1", "0", "0",
                          "--connect", where, "--prefix", "mine", "--timeout", "1"], capsys)
    assert status == 1
    assert_clean(err)
    assert f"tried {where}, prefix 'mine'" in err and "nothing accepts connections" in err


def test_a_wrong_prefix_is_named(service: ServiceProcess, capsys: pytest.CaptureFixture[str]) -> None:
    status, _, err = run(["stats", "--connect", service.endpoint, "--prefix", "nope", "--timeout", "1"], capsys)
    assert status == 1
    assert_clean(err)
    assert "prefix 'nope'" in err and "answers there, under another prefix than 'nope'" in err
    assert run(["stats", "--connect", service.endpoint], capsys)[0] == 0  # the right prefix, the same service


def test_a_login_is_asked_for_where_one_is_needed(accounts: tuple[ServiceProcess, Path],
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    svc, folder = accounts
    status, _, err = run(["stats", "--connect", svc.endpoint, "--timeout", "1"], capsys)
    assert status == 1
    assert_clean(err)
    assert "refused the Zenoh session" in err and "--users" in err and "--user NAME" in err

    status, _, err = run(["stats", "--connect", svc.endpoint, "--timeout", "1", "--user", "alice",
                          "--password-file", str(folder / "wrong")], capsys)
    assert status == 1
    assert_clean(err)
    assert "refused the Zenoh session for user 'alice'" in err and "wrong password" in err

    status, out, err = run(["stats", "--connect", svc.endpoint, "--user", "alice",
                            "--password-file", str(folder / "right")], capsys)
    assert status == 0, err  # the same service answers the right login
    assert "instance" in out


def test_service_refusals_are_told_without_class_names(service: ServiceProcess,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    conn = ["--connect", service.endpoint]
    # 20 + 500 = 520: outside the landblock and its neighbours; named as the target, not as what was typed
    status, _, err = run(["move", "--start", "A9B40001", "20", "20", "60", "--offset", "500", "0", "0", *conn], capsys)
    assert status == 1
    assert_clean(err)
    assert "move.offset[0] (the target: current position + offset): 520.0 is outside" in err
    status, _, err = run(["move", "--start", "A9B40000", "20", "20", "60", "--offset", "1", "0", "0", *conn], capsys)
    assert status == 1 and "unknown_cell: cell id A9B40000" in err
    assert_clean(err)
    status, _, err = run(["ground", "12340001", "20", "20", "60", *conn], capsys)
    assert status == 1 and "acphys/lb/1234/ground" in err and "but none served that request" in err  # nobody owns 1234
    assert_clean(err)


def test_serve_names_its_landblocks_in_hex(service: ServiceProcess) -> None:
    up = next(line for line in service.output if " up; owns " in line)
    assert "owns A9B4,A9B5,AAB4,AAB5 under" in up and "43444" not in up  # 0xA9B4 == 43444


def test_zenoh_refusals_are_zenohs_reason_without_its_source_paths(tmp_path: Path,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "missing.json5"
    status, _, err = run(["stats", "--zenoh-config", str(missing)], capsys)
    assert status == 1
    assert_clean(err)
    assert f"Zenoh cannot open a session (tried the endpoints of {missing}" in err and "No such file" in err
    broken = tmp_path / "broken.json5"
    broken.write_text("{bad", encoding="utf-8")
    status, _, err = run(["stats", "--zenoh-config", str(broken)], capsys)
    assert status == 1
    assert_clean(err)
    assert "line 1, column 1" in err


def test_serve_and_router_on_a_port_in_use(service: ServiceProcess) -> None:
    for command in ("serve", "router"):
        r = acphys(command, "--listen", service.endpoint, timeout=60)
        assert r.returncode == 2, r.stderr  # serve's and router's status when they cannot start
        assert_clean(r.stderr)
        assert f"acphys {command}: cannot start" in r.stderr and "Address already in use" in r.stderr


def test_an_unforeseen_error_is_one_line_unless_the_traceback_is_asked_for(
        capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch) -> None:
    import clients.__main__

    def broken(_args: object) -> int:
        raise RuntimeError("the stats table is upside down")

    monkeypatch.setattr(clients.__main__, "_cmd_stats", broken)
    status, _, err = run(["stats"], capsys)
    assert status == 1
    assert_clean(err)
    assert err.startswith("acphys stats: internal error: the stats table is upside down") and err.count("\n") == 1
    monkeypatch.setenv("ACPHYS_TRACEBACK", "1")
    status, _, err = run(["stats"], capsys)
    assert status == 1 and "Traceback" in err and "RuntimeError" in err
