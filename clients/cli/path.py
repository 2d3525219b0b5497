"""`acphys path`: a path a walker can walk, asked of the service (docs/protocol.md, "Paths").

    acphys path --from A9B40024 100 96 112.5 --to A9B40100 107 109.5 112.5   # a player-sized walker
    acphys path --id 100000001 --to A9B40035 150 120 112.5 --json          # a registered mover
    acphys path --from ... --to ... --mover walker.json --max-distance 200 --budget 20000

Prints whether a path was found, its length and each waypoint (cell and landblock metres), or with
`--json` the answer's wire map. `add_path_command` adds it to an argparse subparsers object; it sets
`func` (args -> exit code) on its namespace.
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from typing import Any

from engine import MoverSpec, PathResult
from service.command import positive_int

from clients.cli.failures import USAGE, CommandFailed
from clients.cli.values import PositionAction, hex_id, number
from clients.cli.landblock import parse_landblock
from clients.paths import path_answer_map

__all__ = ["add_path_command", "read_mover_file", "path_rows", "PATH_TIMEOUT"]

#: the command's default --timeout, seconds: the first path to reach a landblock builds its graph (about a
#: second of the service's time per landblock, more on a slow machine), which a 5 s wait may not cover
PATH_TIMEOUT = 30.0

_EPILOG = """\
The walker is a player-sized mover (two spheres of 0.48 m, step up 0.6 m, the demo's player) placed at
--from, unless --mover gives a MoverSpec map (JSON, as docs/protocol.md's "MoverSpec") or --id names a
registered mover, which starts where it stands (then no --from).

Exit status: 0 when the service answered, a path found or not (the answer says which, and why not:
unreachable, budget, not_loaded, start_invalid, goal_invalid), as `acphys ground` exits 0 for no
ground; 1 when the query failed (refused, no service, timeout); 2 for a usage error (a bad option or
--mover file).
"""


def read_mover_file(path: str) -> MoverSpec:
    """The MoverSpec of a `--mover` JSON file; CommandFailed (usage) naming the file and what is wrong."""
    from service.protocol.codec import decode_mover_spec
    from service.protocol.errors import ProtocolError

    try:
        with open(path, encoding="utf-8") as f:
            value = json.load(f)
    except OSError as e:
        raise CommandFailed(f"--mover {path}: {e.strerror or e}", USAGE) from None
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise CommandFailed(f"--mover {path}: not JSON ({e})", USAGE) from None
    try:
        return decode_mover_spec(value, "mover")
    except ProtocolError as e:
        raise CommandFailed(f"--mover {path}: not a MoverSpec: {e.message}", USAGE) from None


def _where(p: Any) -> str:
    o = p.frame.origin
    return f"cell {p.cell_id:08X}  ({o.x:.4f}, {o.y:.4f}, {o.z:.4f})"


def path_rows(r: PathResult) -> list[tuple[str, str]]:
    """The readable answer: found or not (and why), length, searched nodes, each waypoint."""
    if not r.found:
        return [("found", "no"), ("reason", str(r.reason)), ("detail", r.detail or "-"), ("expanded", str(r.expanded))]
    rows = [("found", "yes"), ("length", f"{r.length:.4f} m"), ("expanded", str(r.expanded)),
            ("waypoints", str(len(r.waypoints)))]
    rows += [(str(i), _where(p)) for i, p in enumerate(r.waypoints)]
    return rows


def _run(args: argparse.Namespace) -> int:
    from clients.cli.connection import connect_client

    if args.id is not None and args.mover is not None:
        raise CommandFailed("--mover gives the shape of a walker placed at --from; an --id mover has its own", USAGE)
    if args.id is None and args.landblock is not None:
        raise CommandFailed("--landblock says where an --id mover is; with --from the start's landblock is used", USAGE)
    walker: MoverSpec | int
    if args.id is not None:
        walker = args.id
    elif args.mover is not None:
        walker = read_mover_file(args.mover)
    else:
        from clients.cli.player import player_mover

        walker = player_mover()
    with connect_client(args) as c:
        if args.id is not None and args.landblock is not None:
            c.locate(args.id, args.landblock)
        answer = c.path(walker, args.start, args.goal, max_distance=args.max_distance, budget=args.budget,
                        avoid_movers=args.avoid_movers)
    if args.json:
        print(json.dumps(path_answer_map(answer), indent=2))
    else:
        for k, v in path_rows(answer):
            print(f"{k:>9}  {v}")
    return 0


def _distance(text: str) -> float:
    value = number(text)
    if value <= 0.0:
        raise argparse.ArgumentTypeError(f"{text!r}: a longest path is more than 0 m")
    return value


def add_path_command(subparsers: Any, conn_args: Callable[[argparse.ArgumentParser], None]) -> None:
    """Add `acphys path`; `conn_args` adds the connection options (clients.__main__)."""
    p = subparsers.add_parser("path", help="a path a walker can walk from one point to another (moves nothing)",
                              description="Ask the service for a path a walker can walk, proven by walking it "
                                          "with the walker's shape; nothing is moved.",
                              epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    pos = {"nargs": 4, "metavar": ("CELL", "X", "Y", "Z"), "action": PositionAction}
    who = p.add_mutually_exclusive_group(required=True)
    who.add_argument("--from", dest="start", help="the start: hex cell id and landblock metres", **pos)
    who.add_argument("--id", type=hex_id, help="walk a registered mover (hex id) from where it stands")
    p.add_argument("--to", dest="goal", required=True, help="the goal: hex cell id and landblock metres", **pos)
    p.add_argument("--mover", metavar="FILE", help="the walker's MoverSpec as a JSON file (default: player-sized)")
    p.add_argument("--landblock", type=parse_landblock, help="the landblock (hex XXYY) the --id mover is in")
    p.add_argument("--max-distance", type=_distance, metavar="M", help="the longest path wanted, metres")
    p.add_argument("--budget", type=positive_int, metavar="N",
                   help="graph nodes the search may expand (default the service's, 10000)")
    p.add_argument("--avoid-movers", action="store_true", help="the movers standing now are obstacles")
    conn_args(p)
    p.set_defaults(timeout=PATH_TIMEOUT, func=_run)
    p.add_argument("--json", action="store_true", help="print the answer's wire map as JSON")
