"""`acphys view`: a live map of a service's movers in the browser.

A Starlette app served by uvicorn on loopback (default http://127.0.0.1:8765/):

- `/` and `/static/...`: the page (plain JavaScript on a canvas, no outside resources);
- `/api/info`: what the view watches (prefix, endpoints, the service's instances);
- `/api/landblocks`: the landblocks to draw: those the service's instances have
  loaded, and those a mover was seen in;
- `/api/terrain/XXYY`: a landblock's height grid (`clients.view.terrain`);
- `/api/objects/XXYY`: the outlines of a landblock's buildings and static
  objects (`clients.view.objects`);
- `/api/movers`: every mover's latest State;
- `/api/events`: server-sent events, one `state` event per new State
  (`clients.view.board` subscribes to the service's state publications) and
  one `removed` event per mover the service no longer holds
  (`clients.view.removals` asks after movers that fell quiet);
- `/api/paths`: the paths asked (`--path`, or two shift-clicks on the map,
  posted to `/api/path`) with the service's answers, their waypoints for the
  page to draw (`clients.view.paths`).

The page colours movers by contact state, draws buildings and objects, pans
and zooms, shows a mover's State when clicked, and draws the paths asked. A mover appears with its
first State published after the view started (the protocol has no "list
every mover" query).
"""

from __future__ import annotations

import argparse
import asyncio
import sys
import threading
import time
from collections.abc import Callable
from importlib import resources
from typing import Any

from clients.view.board import MoverBoard
from clients.view.objects import ObjectSource
from clients.view.paths import PathBook, outdoor_position, parse_path_words
from clients.view.removals import RemovalWatch, held_by_service
from clients.view.terrain import TerrainSource

__all__ = ["add_view_arguments", "build_app", "run_view"]

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8765
_LANDBLOCK_REFRESH_S = 5.0
_KEEPALIVE_S = 10


def add_view_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--host", default=DEFAULT_HOST,
                   help="address the web page is served on (default %(default)s: this machine only)")
    p.add_argument("--port", type=int, default=DEFAULT_PORT, help="web port (default %(default)s; 0 picks a free one)")
    src = p.add_mutually_exclusive_group()
    src.add_argument("--scene", metavar="FILE", help="the scene the service serves (for the terrain; default the demo world)")
    src.add_argument("--dat-dir", metavar="DIR", help="the dat directory the service serves (for the terrain)")
    p.add_argument("--path", nargs=8, action="append", default=[],
                   metavar=("FROM_CELL", "X", "Y", "Z", "TO_CELL", "X", "Y", "Z"),
                   help="ask the service for a path a player-sized walker can walk from one point to another (hex "
                        "cell ids, landblock metres, as `acphys path --from ... --to ...`) and draw it on the map; "
                        "repeat for more. On the page, shift-click two points for a path between them")


class _Landblocks:
    """The service's loaded landblocks, asked for at most every few seconds."""

    def __init__(self, client: Any) -> None:
        self.client = client
        self.instances: list[str] = []
        self._loaded: set[int] = set()
        self._asked = 0.0

    def current(self, board: MoverBoard) -> list[int]:
        now = time.monotonic()
        if now - self._asked > _LANDBLOCK_REFRESH_S:
            self._asked = now
            try:
                infos = self.client.landblocks(timeout=1.0)
                self.instances = sorted(i.instance for i in infos)
                self._loaded = {int(lb) for i in infos for lb in i.get("loaded", []) or []}
            except Exception:  # the service is away for now: keep what we knew
                pass
        seen = {int(s["landblock"]) for s in board.snapshot() if isinstance(s.get("landblock"), int)}
        return sorted(self._loaded | seen)


def build_app(board: MoverBoard, terrain: TerrainSource, landblocks: _Landblocks | None, info: dict[str, Any],
              objects: ObjectSource | None = None, paths: PathBook | None = None,
              height_at: Callable[[int, float, float], float] | None = None) -> Any:
    """The Starlette application of the live map. `paths` answers the paths asked; `height_at(cell, x, y)`
    (the terrain's height) puts a shift-clicked point on the ground."""
    from sse_starlette.sse import EventSourceResponse
    from starlette.applications import Starlette
    from starlette.requests import Request
    from starlette.responses import FileResponse, JSONResponse, Response
    from starlette.routing import Mount, Route
    from starlette.staticfiles import StaticFiles

    static_dir = str(resources.files("clients").joinpath("view", "static"))

    async def index(_: Request) -> Response:
        return FileResponse(f"{static_dir}/index.html", media_type="text/html")

    async def api_info(_: Request) -> Response:
        out = dict(info)
        if landblocks is not None and landblocks.instances:
            out["instances"] = landblocks.instances
        return JSONResponse(out)

    async def api_landblocks(_: Request) -> Response:
        lbs = await asyncio.to_thread(landblocks.current, board) if landblocks is not None else \
            sorted({int(s["landblock"]) for s in board.snapshot()})
        return JSONResponse([f"{lb:04X}" for lb in lbs])

    def landblock_of(request: Request) -> int | Response:
        text = request.path_params["lb"]
        try:
            lb = int(text, 16)
            if not 0 <= lb <= 0xFFFF or len(text) != 4:
                raise ValueError
        except ValueError:
            return JSONResponse({"error": f"not a landblock id (XXYY in hex): {text!r}"}, status_code=400)
        return lb

    async def api_terrain(request: Request) -> Response:
        lb = landblock_of(request)
        if isinstance(lb, Response):
            return lb
        grid = await asyncio.to_thread(terrain.grid, lb)
        if grid is None:
            return JSONResponse({"error": f"the view's world has no landblock {lb:04X}"}, status_code=404)
        return JSONResponse(grid.to_json())

    async def api_objects(request: Request) -> Response:
        lb = landblock_of(request)
        if isinstance(lb, Response):
            return lb
        found = await asyncio.to_thread(objects.objects, lb) if objects is not None else None
        if found is None:
            return JSONResponse({"error": f"the view's world has no landblock {lb:04X}"}, status_code=404)
        return JSONResponse(found.to_json())

    async def api_movers(_: Request) -> Response:
        return JSONResponse(board.snapshot())

    async def api_paths(_: Request) -> Response:
        return JSONResponse(paths.to_json() if paths is not None else [])

    async def api_path(request: Request) -> Response:
        """Two points in global map metres, {"from": [x, y], "to": [x, y]}: the path between them, answered
        (the request waits for the service; the page draws it when it comes)."""
        if paths is None or height_at is None:
            return JSONResponse({"error": "this view asks no paths"}, status_code=404)
        try:
            body = await request.json()
            xys = [(float(body[k][0]), float(body[k][1])) for k in ("from", "to")]
        except (ValueError, TypeError, KeyError, IndexError) as e:
            return JSONResponse({"error": f"not two points {{\"from\": [x, y], \"to\": [x, y]}}: {e}"},
                                status_code=400)
        try:
            ends = [outdoor_position(x, y, height_at) for x, y in xys]
        except Exception as e:  # off the map, or a landblock the view's world does not have
            return JSONResponse({"error": f"no terrain there: {e}"}, status_code=404)
        entry = await asyncio.to_thread(paths.answer, paths.add(ends[0], ends[1]))
        return JSONResponse(entry.to_json())

    async def api_events(request: Request) -> Response:
        q = board.listen()

        async def stream() -> Any:
            try:
                while True:
                    event, text = await q.get()
                    yield {"event": event, "data": text}
            finally:
                board.unlisten(q)

        return EventSourceResponse(stream(), ping=_KEEPALIVE_S)

    return Starlette(routes=[
        Route("/", index),
        Route("/api/info", api_info),
        Route("/api/landblocks", api_landblocks),
        Route("/api/terrain/{lb}", api_terrain),
        Route("/api/objects/{lb}", api_objects),
        Route("/api/movers", api_movers),
        Route("/api/events", api_events),
        Route("/api/paths", api_paths),
        Route("/api/path", api_path, methods=["POST"]),
        Mount("/static", StaticFiles(directory=static_dir), name="static"),
    ])


def run_view(args: argparse.Namespace) -> int:
    """Serve the live map until Ctrl-C / SIGTERM."""
    try:
        import uvicorn
    except ImportError:
        print("acphys view: the live map needs its web packages: pip install 'acphys[view]'", file=sys.stderr)
        return 2
    from service.world_source import open_world

    from clients.cli.connection import connect_client
    from clients.cli.player import player_mover
    from clients.demo.world import demo_scene_path
    from clients.view.paths import PATH_TIMEOUT_S
    from clients.cli.which_service import describe_service

    scene = args.scene if args.scene is not None or args.dat_dir is not None else str(demo_scene_path())
    try:
        asked = [parse_path_words(words) for words in args.path]
    except argparse.ArgumentTypeError as e:
        print(f"acphys view: --path: {e}", file=sys.stderr)
        return 2
    try:
        world = open_world(scene=scene, dat_dir=args.dat_dir)
    except Exception as e:
        print(f"acphys view: cannot open the world for the terrain: {e}", file=sys.stderr)
        return 2
    with connect_client(args) as client:
        board = MoverBoard(client.session, client.keys.prefix)
        board.start()
        removals = RemovalWatch(board, held_by_service(client))
        removals.start()
        lbs = _Landblocks(client)
        instances = [h.instance for h in client.health(timeout=min(args.timeout, 2.0))]
        print(describe_service(instances, args.connect, client.keys.prefix, args.zenoh_config), file=sys.stderr)
        if not instances:
            print("acphys view: no service answers yet; movers appear when one publishes states", file=sys.stderr)
        info = {"prefix": client.keys.prefix, "connect": args.connect or ["tcp/127.0.0.1:7447"],
                "world": args.dat_dir or scene, "instances": instances}
        world_lock = threading.Lock()  # the terrain and the objects read the one world from the server's threads

        def height_at(cell: int, x: float, y: float) -> float:
            with world_lock:
                return float(world.terrain_height(cell, x, y))

        walker = player_mover()  # player-sized, as `acphys path` has it
        book = PathBook(lambda start, goal: client.path(walker, start, goal, timeout=PATH_TIMEOUT_S))
        book.answer_in_background([book.add(start, goal) for start, goal in asked])
        app = build_app(board, TerrainSource(world, lock=world_lock), lbs, info, ObjectSource(world, lock=world_lock),
                        book, height_at)
        config = uvicorn.Config(app, host=args.host, port=args.port, log_level="warning", lifespan="off")
        server = uvicorn.Server(config)

        async def announce() -> None:  # the real port (when --port 0) once the socket is bound
            while not server.started:
                await asyncio.sleep(0.05)
            for s in server.servers:
                for sock in s.sockets:
                    host, port = sock.getsockname()[:2]
                    print(f"acphys view: serving the live map on http://{host}:{port}/ (Ctrl-C stops it)",
                          file=sys.stderr, flush=True)
                    return

        async def main() -> None:
            task = asyncio.create_task(announce())
            await server.serve()
            task.cancel()

        try:
            asyncio.run(main())
        except SystemExit:  # uvicorn exits when it cannot bind (it has logged why)
            print(f"acphys view: cannot serve on {args.host}:{args.port} (in use by another program?): "
                  "pick another with --port", file=sys.stderr)
            return 1
        finally:
            removals.close()
            board.close()
    return 0
