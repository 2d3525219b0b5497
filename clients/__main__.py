"""The `acphys` command line: serve, move, demo, stats, view.

    acphys serve                      # the demo world on tcp/127.0.0.1:7447
    acphys demo --out walk.png        # walk the demo (embedded service if none runs)
    acphys move --start A9B40001 20 20 60 --offset 1 0 0
    acphys stats
    acphys ground A9B4000B 40 50 60    # spatial queries: ground, sight, ray, place (clients/cli/query.py)
    acphys path --from A9B40024 100 96 112.5 --to A9B40100 107 109.5 112.5   # a walkable path (clients/cli/path.py)
    acphys view                       # a live map of the movers on http://127.0.0.1:8765/
    acphys router --listen tcp/0.0.0.0:7447   # a Zenoh router for instances on several machines
    acphys --version                  # the version and the protocol version

A failed command says why in one message on stderr and exits 1; a wrong command line exits 2
(clients/cli/parser.py, cli_values.py, endpoints.py); no command shows a traceback (cli_failures.py).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from typing import Any

from service.main import add_serve_arguments, serve
from service.bus.router import add_router_arguments, run_router

from clients.cli.failures import USAGE, CommandFailed, report_failure
from clients.cli.parser import CommandParser, walk_parsers
from clients.cli.values import PositionAction, TargetAction, hex_id, number
from clients.cli.connection import add_connection_arguments, connect_client
from clients.cli.endpoints import connect_endpoint, key_prefix, listen_endpoint, tcp_port
from clients.cli.landblock import add_landblock_commands, parse_landblock
from clients.cli.path import add_path_command
from clients.cli.query import add_query_commands

__all__ = ["main", "build_parser", "version_text"]


def version_text() -> str:
    """`acphys 0.1.0 (protocol version 1, docs/protocol.md)`: the installed package's version and the wire
    protocol's (the `v` of every message)."""
    from importlib.metadata import PackageNotFoundError, version

    from service.protocol.wire import PROTOCOL_VERSION

    try:
        package = version("acphys")
    except PackageNotFoundError:  # run from a source tree that was never installed
        package = "(not installed)"
    return f"acphys {package} (protocol version {PROTOCOL_VERSION}, docs/protocol.md)"


#: the network options every command that has them checks as they are parsed (clients/cli/endpoints.py)
_BUS_OPTION_TYPES = {"--listen": listen_endpoint, "--connect": connect_endpoint, "--prefix": key_prefix,
                     "--port": tcp_port}


def _check_bus_options(parser: argparse.ArgumentParser) -> None:
    """Every command's --listen, --connect, --prefix and --port (serve's and router's too) checked as parsed."""
    for _, p in walk_parsers(parser):
        for action in p._actions:
            for option, check in _BUS_OPTION_TYPES.items():
                if option in action.option_strings:
                    action.type = check


def build_parser() -> argparse.ArgumentParser:
    p = CommandParser(prog="acphys", description="Asheron's Call collision physics on a Zenoh bus.")
    p.add_argument("--version", action="version", version=version_text(),
                   help="print the version and the protocol version, and exit")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    s = sub.add_parser("serve", help="run the service (the built-in demo world unless --scene/--dat-dir)")
    add_serve_arguments(s)

    r = sub.add_parser("router", help="run a Zenoh router (router mode) for instances and clients to connect to")
    add_router_arguments(r)
    r.set_defaults(func=run_router)

    m = sub.add_parser("move", help="send one move and print the result")
    add_connection_arguments(m)
    who = m.add_mutually_exclusive_group(required=True)
    who.add_argument("--id", type=hex_id, help="move this registered mover (hex id)")
    who.add_argument("--start", nargs=4, metavar=("CELL", "X", "Y", "Z"), action=PositionAction,
                     help="register a player-sized mover here (hex cell id, landblock metres), move it, remove it")
    m.add_argument("--landblock", type=parse_landblock, help="landblock (hex XXYY) the --id mover is in")
    what = m.add_mutually_exclusive_group(required=True)
    what.add_argument("--to", nargs="+", metavar="V", action=TargetAction,
                      help="target: X Y Z in the current cell, or CELL X Y Z")
    what.add_argument("--offset", nargs=3, type=number, metavar=("DX", "DY", "DZ"), help="target = current + offset")
    what.add_argument("--motion", nargs=3, type=number, metavar=("DX", "DY", "DZ"),
                      help="physics step with this own motion (object frame); needs --dt")
    m.add_argument("--dt", type=number, default=0.1,
                   help="seconds of a --motion step (default %(default)s); a --start mover is first put on the ground")
    m.add_argument("--json", action="store_true", help="print the State map as JSON")

    d = sub.add_parser("demo", help="walk a mover over the demo world; print a table and save a map")
    add_connection_arguments(d)
    d.add_argument("--embedded", action="store_true", help="always start an embedded service")
    d.add_argument("--out", default="acphys-demo.png", help="PNG map to write (default %(default)s)")
    d.add_argument("--quiet", action="store_true", help="no progress display")

    v = sub.add_parser("view", help="serve a live map of the service's movers to a web browser (loopback by default)")
    add_connection_arguments(v)
    from clients.view.server import add_view_arguments

    add_view_arguments(v)

    st = sub.add_parser("stats", help="print every instance's health and statistics")
    add_connection_arguments(st)
    st.add_argument("--json", action="store_true", help="print the raw stats maps as JSON")
    add_landblock_commands(sub)
    add_query_commands(sub, add_connection_arguments)
    add_path_command(sub, add_connection_arguments)
    _check_bus_options(p)
    return p


def main(argv: list[str] | None = None) -> int:
    """Run one command: its exit status (0; 1 when it failed, 2 for a usage error; never a traceback)."""
    args = build_parser().parse_args(argv)  # a usage error exits here with status 2
    try:
        return _run(args)
    except KeyboardInterrupt:
        return 130
    except Exception as e:
        return report_failure(args.command, e, args)


def _run(args: argparse.Namespace) -> int:
    func = getattr(args, "func", None)
    if func is not None:  # subcommands added by other modules set their own handler
        return int(func(args))
    if args.command == "serve":
        if args.scene is None and args.dat_dir is None:
            from clients.demo.world import demo_scene_path

            args.scene = str(demo_scene_path())
        return serve(args)
    if args.command == "move":
        return _cmd_move(args)
    if args.command == "demo":
        from clients.demo.command import run_demo

        _check_out_directory(args.out)
        return run_demo(args)
    if args.command == "stats":
        return _cmd_stats(args)
    if args.command == "view":
        from clients.view.server import run_view

        return run_view(args)
    return USAGE


def _check_out_directory(path: str) -> None:
    """A usage error, before the walk, when --out names a file in a directory that is not there."""
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        raise CommandFailed(f"--out {path}: there is no directory {folder}", USAGE)


def _state_rows(st: Any) -> list[tuple[str, str]]:
    r = st.result
    o, q = r.position.origin, r.position.frame.orientation

    def vec(v: Any) -> str:
        return "-" if v is None else f"({v.x:.4f}, {v.y:.4f}, {v.z:.4f})"

    plane = "-" if r.contact_plane is None else (
        f"n {vec(r.contact_plane.normal)} d {r.contact_plane.d:.4f} (cell {r.contact_plane_cell:08X})")
    return [
        ("mover", f"{st.id:X}"),
        ("seq", str(st.seq)),
        ("ok", str(r.ok)),
        ("transition", r.transition_state),
        ("cell", f"{r.position.cell_id:08X}"),
        ("origin", f"({o.x:.4f}, {o.y:.4f}, {o.z:.4f})"),
        ("orientation", f"[{q.w:.4f}, {q.x:.4f}, {q.y:.4f}, {q.z:.4f}]"),
        ("contact", str(r.contact)),
        ("on walkable", str(r.on_walkable)),
        ("contact plane", plane),
        ("collision normal", vec(r.collision_normal)),
        ("sliding normal", vec(r.sliding_normal)),
        ("transient state", ", ".join(r.transient_state) or "-"),
    ]


def _cmd_move(args: argparse.Namespace) -> int:
    from engine.geometry import Position
    from service.protocol.codec import encode_state

    from clients.cli.player import player_mover
    from clients.cli.ground import drop_to_ground
    from clients.types import Move

    with connect_client(args) as c:
        temp = args.id is None
        if temp:
            registered = c.register(player_mover(), args.start)
            mover_id = registered.id
            if args.motion is not None:  # a step from rest in the air does nothing: stand it on the ground first
                try:
                    placed = drop_to_ground(c, registered)
                except BaseException:
                    c.remove(mover_id)
                    raise
                o = placed.position.origin
                print(f"placed on the ground at ({o.x:.2f}, {o.y:.2f}, {o.z:.2f}) in cell {placed.position.cell_id:08X}"
                      if placed.contact else "no ground below the start: the step starts in the air", file=sys.stderr)
        else:
            mover_id = args.id
            if args.landblock is not None:
                c.locate(mover_id, args.landblock)
        try:
            if args.to is not None:
                cell, origin = args.to
                move = Move(mover_id, to=Position.at(cell or 0, origin), keep_cell=cell is not None)
            elif args.offset is not None:
                move = Move(mover_id, offset=tuple(args.offset))
            else:
                move = Move(mover_id, motion=tuple(args.motion), dt=args.dt)
            st = c.send(move)
            _print_instance(c, args, st.landblock)
        finally:
            if temp:
                c.remove(mover_id)
    if args.json:
        print(json.dumps(encode_state(st.id, st.seq, st.result, st.result.collide_objects, st.tag), indent=2))
    else:
        for k, v in _state_rows(st):
            print(f"{k:>17}  {v}")
    return 0


def _print_instance(c: Any, args: argparse.Namespace, lb: int) -> None:
    """Say on stderr which instance owns landblock `lb` (the one that answered), and where it was reached."""
    from clients.cli.which_service import owner_of, print_service

    try:
        owners = owner_of(c.landblocks(timeout=min(args.timeout, 2.0)), lb)
    except Exception:  # only a courtesy line: the move itself succeeded
        owners = []
    print_service(owners, args.connect, c.keys.prefix, args.zenoh_config)


def _cmd_stats(args: argparse.Namespace) -> int:
    from clients.cli.which_service import print_service

    from clients.cli.no_answer import explain_no_answer

    with connect_client(args) as c:
        stats = c.stats()
    if not stats:
        raise CommandFailed(explain_no_answer(args))
    print_service([s.instance for s in stats], args.connect, c.keys.prefix, args.zenoh_config)
    if args.json:
        print(json.dumps([s.data for s in stats], indent=2, default=str))
        return 0
    for s in stats:
        d = s.data
        lat = d.get("latency_ms", {})
        print(f"instance {s.instance}")
        print(f"  uptime        {d.get('uptime_s', 0):.1f} s   movers {d.get('movers', 0)}   "
              f"queue {d.get('queue_depth', 0)}/{d.get('queue_capacity', 0)}")
        print("  requests      " + ", ".join(f"{k} {v}" for k, v in sorted(d.get("requests", {}).items())))
        print(f"  moves         {d.get('moves', 0)}")
        errs = d.get("errors", {})
        print("  errors        " + (", ".join(f"{k} {v}" for k, v in sorted(errs.items())) or "none"))
        print(f"  latency (ms)  p50 {lat.get('p50', 0):.3f}  p90 {lat.get('p90', 0):.3f}  "
              f"p99 {lat.get('p99', 0):.3f}  max {lat.get('max', 0):.3f}  over {lat.get('window', 0)} moves")
        print("  landblocks    " + " ".join(f"{lb:04X}" for lb in d.get("loaded_landblocks", [])))
        print("  cache         " + ", ".join(f"{k} {v}" for k, v in sorted(d.get("cache", {}).items())))
        h = d.get("handovers", {})
        print(f"  hand-overs    out {h.get('out', 0)}, in {h.get('in', 0)}, failed {h.get('failed', 0)}")
        procs = d.get("worker_processes") or []
        if procs:  # a `serve --workers N` service: its engine processes
            print(f"  workers       {d.get('workers', len(procs))}, {d.get('workers_ok', 0)} answering")
            for w in procs:
                code = f", exit code {w['exit_code']}" if w.get("exit_code") is not None else ""
                print(f"    {w.get('index')}: {w.get('status')}, pid {w.get('pid')}, instance {w.get('instance')}{code}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
