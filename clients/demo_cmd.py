"""`acphys demo`: walk the demo world, print what happened, save the map."""

from __future__ import annotations

import argparse
import math
import sys
from contextlib import ExitStack

from .client import Client
from .demo_map import height_grid, render_map
from .demo_walk import DT, LEGS, SPEED, START, walk_demo
from .demo_world import DEMO_LANDBLOCKS, demo_scene_path, global_to_cell
from .embedded import EmbeddedService
from .errors import AcphysError
from .png import write_png
from .progress import Progress

__all__ = ["run_demo"]


def _estimated_steps() -> int:
    total, (x, y) = 0.0, START
    for _, (wx, wy) in LEGS:
        total += math.hypot(wx - x, wy - y)
        x, y = wx, wy
    return int(total / (SPEED * DT))


def _connect(args: argparse.Namespace, stack: ExitStack) -> Client:
    """A client of a running service that holds the demo world, or of an embedded one."""
    if not args.embedded:
        c = stack.enter_context(Client(args.connect, config_file=args.zenoh_config, prefix=args.prefix,
                                        timeout=args.timeout))
        if c.health(timeout=1.0):
            try:
                for lb in DEMO_LANDBLOCKS:
                    c.load_landblock(lb)
                print("using the running service", file=sys.stderr)
                return c
            except AcphysError as e:
                print(f"the running service cannot serve the demo world ({e}); starting an embedded one",
                      file=sys.stderr)
        else:
            print("no service answers; starting an embedded one", file=sys.stderr)
    svc = stack.enter_context(EmbeddedService(demo_scene_path(), prefix=args.prefix))
    c = stack.enter_context(Client([svc.endpoint], prefix=args.prefix, timeout=args.timeout))
    c.wait_ready()
    return c


def _table(res: object) -> str:
    from .demo_walk import WalkResult

    assert isinstance(res, WalkResult)
    head = f"{'leg':<27} {'steps':>5} {'from (x, y, z)':>22} {'to (x, y, z)':>22} {'z range':>13} " \
           f"{'air':>4} {'steep':>5} {'hits':>4}  outcome"
    lines = [head, "-" * len(head)]
    for leg in res.legs:
        def xyz(p: tuple[float, float, float]) -> str:
            return f"({p[0]:5.1f}, {p[1]:5.1f}, {p[2]:5.1f})"

        zr = f"{leg.lowest_z:5.1f}..{leg.highest_z:5.1f}" if leg.steps else "-"
        lines.append(f"{leg.name:<27} {leg.steps:>5} {xyz(leg.start):>22} {xyz(leg.end):>22} {zr:>13} "
                     f"{leg.airborne_steps:>4} {leg.unwalkable_steps:>5} {leg.collisions:>4}  {leg.outcome}")
    return "\n".join(lines)


def run_demo(args: argparse.Namespace) -> int:
    with ExitStack() as stack:
        client = _connect(args, stack)
        progress = None if args.quiet else Progress(_estimated_steps(), "walking")
        res = walk_demo(client, on_step=progress.update if progress else None)
        if progress:
            progress.done()
    print(_table(res))
    print()
    print("events:")
    for e in res.events:
        print(f"  {e}")
    print(f"\n{res.steps} physics steps; 'air' = steps without contact, 'steep' = in contact with unwalkable "
          "ground, 'hits' = steps with a collision normal")

    from engine import load_scene

    world = load_scene(str(demo_scene_path()))

    def height_at(x: float, y: float) -> float:
        cell, lx, ly = global_to_cell(x, y)
        return world.terrain_height(cell, lx, ly)

    heights = height_grid(height_at, 384)
    write_png(args.out, render_map(heights, 1.0, res.path, scale=2))
    print(f"map written to {args.out} (black: walking, orange: on steep ground, blue: in the air, "
          "red x: collision, red tint: slopes steeper than FloorZ)")
    return 0
