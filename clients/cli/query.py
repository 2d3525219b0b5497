"""`acphys sight`, `acphys ray`, `acphys ground` and `acphys place`: one spatial query asked of the service.

    acphys ground A9B4000B 40 50 60                               # the surface under a point
    acphys sight --from A9B4000B 40 50 60 --to A9B40026 100 120 60  # is the line clear?
    acphys ray --from A9B4000B 40 50 45 --to A9B40013 60 50 38 --radius 0.1
    acphys place A9B4000B 40 50 44                                # where a player-sized mover would be placed

Positions are a hex cell id and landblock-local metres. Each prints a readable answer, or with `--json`
the answer's wire map (docs/protocol.md, "Spatial queries"). `add_query_commands` adds them to an
argparse subparsers object; each sets `func` (args -> exit code) on its namespace.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from typing import Any

from engine.geometry import Position, Vec3
from service.protocol import write_answer

from clients.cli.values import PositionAction, cell_id, number, parse_position

__all__ = ["QUERY_COMMANDS", "add_query_commands", "parse_position"]

QUERY_COMMANDS = ("sight", "ray", "ground", "place")


def _at(args: argparse.Namespace) -> Position:
    """The position of `ground` and `place`: their CELL X Y Z words, read by argparse."""
    return Position.at(args.cell, Vec3(args.x, args.y, args.z))


def _vec(v: Vec3 | None) -> str:
    return "-" if v is None else f"({v.x:.4f}, {v.y:.4f}, {v.z:.4f})"


def _where(p: Position | None) -> str:
    if p is None:
        return "-"
    o = p.frame.origin
    return f"({o.x:.4f}, {o.y:.4f}, {o.z:.4f}) in cell {p.cell_id:08X}"


def _blocker(b: Any) -> str:
    if b is None:
        return "-"
    return b.kind if b.object_id is None else f"{b.kind} {b.object_id:X}"


def _rows(op: str, a: Any) -> list[tuple[str, str]]:
    if op == "ground":
        if a is None:
            return [("ground", "none within reach")]
        p = a.plane
        return [("z", f"{a.z:.4f}"), ("cell", f"{a.cell:08X}"), ("walkable", str(a.walkable)),
                ("plane", f"n {_vec(p.normal)} d {p.d:.4f}"), ("water depth", f"{a.water_depth:.4f}")]
    if op == "sight":
        if a.clear:
            return [("sight", "clear")]
        return [("sight", "blocked"), ("stopped at", _where(a.stop)), ("normal", _vec(a.normal)), ("by", _blocker(a.blocker))]
    if op == "ray":
        return [("hit", str(a.hit)), ("stopped at", _where(a.position)), ("distance", f"{a.distance:.4f}"),
                ("normal", _vec(a.normal)), ("by", _blocker(a.blocker))]
    plane = "-" if a.contact_plane is None else f"n {_vec(a.contact_plane.normal)} d {a.contact_plane.d:.4f}"
    return [("placement", a.placement_result), ("placed at", _where(a.position)), ("contact", str(a.contact)),
            ("on walkable", str(a.on_walkable)), ("contact plane", plane)]


def _run(op: str, ask: Callable[[Any, argparse.Namespace], Any]) -> Callable[[argparse.Namespace], int]:
    def run(args: argparse.Namespace) -> int:
        from clients.cli.connection import connect_client

        with connect_client(args) as c:
            answer = ask(c, args)
        if args.json:
            print(json.dumps(write_answer(op, answer), indent=2))
        else:
            for k, v in _rows(op, answer):
                print(f"{k:>13}  {v}")
        return 0

    return run


def _ask_place(c: Any, args: argparse.Namespace) -> Any:
    from clients.cli.player import player_mover

    return c.place(player_mover(), _at(args), mode=args.mode, slide=not args.no_slide)


def _add_position(p: argparse.ArgumentParser) -> None:
    """CELL X Y Z as four positionals (argparse cannot show one positional of four named words)."""
    p.add_argument("cell", metavar="CELL", type=cell_id, help="hex cell id, 8 digits XXYYnnnn (e.g. A9B40001)")
    for axis in ("x", "y", "z"):
        p.add_argument(axis, metavar=axis.upper(), type=number, help=f"{axis} in landblock metres")


def add_query_commands(subparsers: Any, conn_args: Callable[[argparse.ArgumentParser], None]) -> None:
    """Add the four query commands; `conn_args` adds the connection options (clients.__main__)."""
    pos = {"nargs": 4, "metavar": ("CELL", "X", "Y", "Z"), "action": PositionAction}
    g = subparsers.add_parser("ground", help="the surface under a point (terrain or an indoor floor)")
    _add_position(g)
    g.add_argument("--max-drop", type=number, help="look at most this far down (metres; default the engine's)")
    g.set_defaults(func=_run("ground", lambda c, a: c.ground(_at(a), a.max_drop)))

    s = subparsers.add_parser("sight", help="is the line from one eye to another clear?")
    s.add_argument("--from", dest="start", required=True, **pos)
    s.add_argument("--to", dest="end", required=True, **pos)
    s.add_argument("--radius", type=number, help="the sight object's radius (default the client's, 0.1 m)")
    s.set_defaults(func=_run("sight", lambda c, a: c.sight(a.start, a.end, a.radius)))

    r = subparsers.add_parser("ray", help="where a sphere swept along a segment first touches something")
    r.add_argument("--from", dest="start", required=True, **pos)
    r.add_argument("--to", dest="end", required=True, **pos)
    r.add_argument("--radius", type=number, default=0.1, help="the swept sphere's radius (default %(default)s m)")
    r.set_defaults(func=_run("ray", lambda c, a: c.ray(a.start, a.end, a.radius)))

    p = subparsers.add_parser("place", help="where a player-sized mover would be placed at a position (places nothing)")
    _add_position(p)
    p.add_argument("--mode", choices=("enter_world", "teleport"), default="enter_world")
    p.add_argument("--no-slide", action="store_true", help="no search for a free spot nearby")
    p.set_defaults(func=_run("place", _ask_place))

    for q in (g, s, r, p):
        conn_args(q)
        q.add_argument("--json", action="store_true", help="print the answer's wire map as JSON")
