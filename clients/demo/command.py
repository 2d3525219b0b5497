"""`acphys demo`: walk the demo world, print what happened, save the map."""

from __future__ import annotations

import argparse
import math
import sys
from contextlib import ExitStack

from tqdm import tqdm

from clients.client import Client
from clients.cli.connection import connect_client
from clients.demo.map import height_grid
from clients.demo.walk import DT, LEGS, PATH_LEG, PATH_STRIDE_M, SPEED, START, numbered_legs, walk_demo
from clients.demo.world import DEMO_LANDBLOCKS, demo_scene_path, global_to_cell
from clients.cli.embedded import EmbeddedService
from clients.errors import AcphysError
from clients.cli.which_service import print_service

__all__ = ["run_demo"]


def _estimated_steps() -> int:
    """About how many steps the walk takes (the legs' straight lines at full speed, the path's in moves
    of 3 m, plus a landing): the progress display's total until the walk ends, when it shows the real count."""
    total, (x, y) = 0.0, START
    for name, (wx, wy) in LEGS:
        metres = math.hypot(wx - x, wy - y)
        total += metres / (PATH_STRIDE_M if name == PATH_LEG else SPEED * DT)
        x, y = wx, wy
    return int(total) + 15


def _connect(args: argparse.Namespace, stack: ExitStack) -> Client:
    """A client of a running service that holds the demo world, or of an embedded one."""
    if not args.embedded:
        c = stack.enter_context(connect_client(args))
        if c.health(timeout=1.0):
            try:
                # only what is missing: with accounts, loading is for the service's --admin users
                loaded = {lb for info in c.landblocks(timeout=1.0) for lb in info.data.get("loaded", [])}
                for lb in DEMO_LANDBLOCKS:
                    if lb not in loaded:
                        c.load_landblock(lb)
                print("using the running service", file=sys.stderr)
                print_service([h.instance for h in c.health(timeout=1.0)], args.connect, c.keys.prefix,
                              args.zenoh_config)
                return c
            except AcphysError as e:
                print(f"the running service cannot serve the demo world ({e}); starting an embedded one",
                      file=sys.stderr)
        else:
            print("no service answers; starting an embedded one", file=sys.stderr)
    svc = stack.enter_context(EmbeddedService(demo_scene_path(), prefix=args.prefix))
    c = stack.enter_context(Client([svc.endpoint], prefix=args.prefix, timeout=args.timeout))
    ready = c.wait_ready()
    print(f"service: embedded instance {ready[0].instance} on {svc.endpoint} (private to this command), "
          f"prefix {args.prefix!r}", file=sys.stderr)
    return c


def _table(res: object) -> str:
    """The walk as a table: the landing (no number: it is not a leg), then one row per leg, numbered as the
    picture numbers them; the steps column adds up to the total."""
    from clients.demo.walk import WalkResult

    assert isinstance(res, WalkResult)
    head = f"{'leg':<30} {'steps':>5} {'from (x, y, z)':>22} {'to (x, y, z)':>22} {'z range':>13} " \
           f"{'air':>4} {'steep':>5} {'hits':>4}  outcome"
    lines = [head, "-" * len(head)]
    for n, leg in [("-", res.landing), *numbered_legs(res.legs)]:
        def xyz(p: tuple[float, float, float]) -> str:
            return f"({p[0]:5.1f}, {p[1]:5.1f}, {p[2]:5.1f})"

        zr = f"{leg.lowest_z:5.1f}..{leg.highest_z:5.1f}" if leg.steps else "-"
        name = f"{n:>2} {leg.name}"
        lines.append(f"{name:<30} {leg.steps:>5} {xyz(leg.start):>22} {xyz(leg.end):>22} {zr:>13} "
                     f"{leg.airborne_steps:>4} {leg.unwalkable_steps:>5} {leg.collisions:>4}  {leg.outcome}")
    lines.append("-" * len(head))
    lines.append(f"{'total':<30} {res.steps:>5}")
    return "\n".join(lines)


def run_demo(args: argparse.Namespace) -> int:
    try:
        import matplotlib  # noqa: F401  (the picture's; checked before walking, to say so at once)
        can_draw = True
    except ImportError:
        can_draw = False
        print("acphys demo: matplotlib is not installed, so no picture will be written "
              "(pip install 'acphys[demo]'; install.sh installs it)", file=sys.stderr)
    with ExitStack() as stack:
        client = _connect(args, stack)
        # the estimate is the bar's total until the walk ends, then the real count is
        bar = None if args.quiet else tqdm(total=_estimated_steps(), desc="walking", unit="step", file=sys.stderr)
        res = walk_demo(client, on_step=(lambda n: bar.update(n - bar.n)) if bar is not None else None)
        if bar is not None:
            bar.total = res.steps
            bar.update(res.steps - bar.n)
            bar.close()
    print(_table(res))
    print()
    print("events (the letters of the picture):")
    from clients.demo.picture import event_letters, render_walk

    for letter, e in zip(event_letters(len(res.events)), res.events):
        print(f"  {letter:>2}  {e}")
    print(f"\n{res.steps - res.moves} physics steps of {DT} s and {res.moves} moves along the path the service "
          f"found (leg {PATH_LEG!r}: its steps are moves); 'air' = steps without contact, 'steep' = in contact "
          "with unwalkable ground, 'hits' = steps with a collision normal")

    if not can_draw:
        return 1

    from engine import load_scene

    world = load_scene(str(demo_scene_path()))

    def height_at(x: float, y: float) -> float:
        cell, lx, ly = global_to_cell(x, y)
        return world.terrain_height(cell, lx, ly)

    heights = height_grid(height_at, 384)
    render_walk(res, heights, 1.0, height_at, args.out)
    print(f"picture written to {args.out}: the map with the numbered legs and lettered events, the village to scale, "
          "the story and the height profile")
    return 0
