"""`acphys inspect` and `acphys load-region`: landblocks straight from a client's dats.

    acphys inspect /games/ac A9B4                      # heights, cells, buildings, objects
    acphys inspect /games/ac A9B4 --export a9b4.json   # ... and save it as an acphys-scene/1 file
    acphys load-region /games/ac A8B3 AAB5             # load a rectangle, with a progress bar

Both read the dats in-process (no service needed). `add_landblock_commands`
adds them to an argparse subparsers object; each sets `func` (args -> exit
code) on its namespace.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Iterable, Iterator
from typing import Any, TextIO

__all__ = [
    "LANDBLOCK_COMMANDS",
    "add_landblock_commands",
    "landblock_summary",
    "parse_landblock",
    "region_ids",
    "run_inspect",
    "run_load_region",
]

LANDBLOCK_COMMANDS = ("inspect", "load-region")


def parse_landblock(text: str) -> int:
    """A landblock id from hex text: `A9B4`, `0xA9B4`, or any cell/record id of it (`A9B40001`)."""
    t = text.strip().lower()
    t = t.removeprefix("0x")
    try:
        value = int(t, 16)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a hex landblock id (XXYY)") from None
    if len(t) > 4:
        value >>= 16
    if not 0 <= value <= 0xFFFF or len(t) > 8:
        raise argparse.ArgumentTypeError(f"{text!r} is not a landblock id (XXYY or XXYYnnnn)")
    return value


def add_landblock_commands(subparsers: Any) -> None:
    """Add `inspect` and `load-region` to an argparse subparsers object."""
    p = subparsers.add_parser("inspect", help="summarise one landblock of a client's dats; optionally export it")
    p.add_argument("dat_dir", metavar="DAT_DIR", help="directory holding client_cell_1.dat and client_portal.dat")
    p.add_argument("landblock", metavar="LANDBLOCK", type=parse_landblock, help="hex XXYY (or a cell id in it)")
    p.add_argument("--export", metavar="OUT.json",
                   help="write the landblock and the portal objects it uses as an acphys-scene/1 file")
    p.add_argument("--name", help="the exported scene's name (default DATDIR-XXYY)")
    p.set_defaults(func=run_inspect)

    r = subparsers.add_parser("load-region", help="load a rectangle of landblocks from a client's dats (progress bar)")
    r.add_argument("dat_dir", metavar="DAT_DIR", help="directory holding client_cell_1.dat and client_portal.dat")
    r.add_argument("corner1", metavar="FROM", type=parse_landblock, help="one corner, hex XXYY")
    r.add_argument("corner2", metavar="TO", type=parse_landblock, help="the opposite corner, hex XXYY (inclusive)")
    r.add_argument("--cache-size", type=int, default=None,
                   help="landblocks the World keeps loaded (default: all of the rectangle)")
    r.add_argument("--terrain-only", action="store_true", help="leave EnvCells, buildings and objects out")
    r.add_argument("--no-progress", action="store_true", help="no progress bar")
    r.set_defaults(func=run_load_region)


# -- inspect ---------------------------------------------------------------------------------------


def landblock_summary(lb: dict[str, Any], height_table: list[float]) -> dict[str, Any]:
    """Counts and height range of a scene-format landblock dict."""
    heights = [int(h) for h in lb["heights"]]
    zs = [height_table[h] for h in heights]
    env_cells = lb.get("env_cells", [])
    return {
        "id": lb["id"],
        "min_z": min(zs),
        "max_z": max(zs),
        "min_height_byte": min(heights),
        "max_height_byte": max(heights),
        "outdoor_cells": 64,
        "env_cells": len(env_cells),
        "cells": 64 + len(env_cells),
        "buildings": len(lb.get("buildings", [])),
        "objects": len(lb.get("objects", [])),
        "env_cell_objects": sum(len(c.get("static_objects", [])) for c in env_cells),
    }


def _print_summary(s: dict[str, Any], directory: str, scene: dict[str, Any], out: TextIO) -> None:
    portal = ", ".join(f"{len(scene.get(k, {}))} {k}" for k in ("environments", "gfx_objs", "setups"))
    print(f"landblock {s['id']}  ({directory})", file=out)
    print(f"  heights    z {s['min_z']:.2f} .. {s['max_z']:.2f} m"
          f"  (height bytes {s['min_height_byte']} .. {s['max_height_byte']})", file=out)  # fmt: skip
    print(f"  cells      {s['cells']}: {s['outdoor_cells']} outdoor + {s['env_cells']} EnvCells", file=out)
    print(f"  EnvCells   {s['env_cells']}", file=out)
    print(f"  buildings  {s['buildings']}", file=out)
    print(f"  objects    {s['objects'] + s['env_cell_objects']}: {s['objects']} on the landblock"
          f" + {s['env_cell_objects']} in EnvCells", file=out)  # fmt: skip
    print(f"  portal     {portal}", file=out)


def run_inspect(args: argparse.Namespace, out: TextIO | None = None) -> int:
    """`acphys inspect`: print the landblock's summary; with --export, write it as a scene."""
    from engine import DatCollection, DatError

    out = out if out is not None else sys.stdout
    lb_id: int = args.landblock
    try:
        with DatCollection(args.dat_dir) as dats:
            if not dats.has_landblock(lb_id):
                print(f"acphys inspect: landblock {lb_id:04X} is not in the dats in {args.dat_dir}", file=sys.stderr)
                return 1
            name = args.name or f"{os.path.basename(os.path.normpath(args.dat_dir))}-{lb_id:04X}"
            scene = dats.scene_dict([lb_id], name=name)
    except DatError as e:
        print(f"acphys inspect: {e}", file=sys.stderr)
        return 1
    _print_summary(landblock_summary(scene["landblocks"][0], scene["height_table"]), args.dat_dir, scene, out)
    if args.export:
        try:
            with open(args.export, "w", encoding="utf-8") as f:
                json.dump(scene, f, indent=1)
                f.write("\n")
        except OSError as e:
            print(f"acphys inspect: cannot write {args.export}: {e.strerror or e}", file=sys.stderr)
            return 1
        print(f"  exported   {args.export} (acphys-scene/1)", file=out)
    return 0


# -- load-region -------------------------------------------------------------------------------------


def region_ids(corner1: int, corner2: int) -> list[int]:
    """Every landblock id of the rectangle between two corners (inclusive), x-major."""
    x0, x1 = sorted((corner1 >> 8, corner2 >> 8))
    y0, y1 = sorted((corner1 & 0xFF, corner2 & 0xFF))
    return [(x << 8) | y for x in range(x0, x1 + 1) for y in range(y0, y1 + 1)]


def _progress(items: list[int], enabled: bool) -> Iterator[int]:
    """`items` with a progress bar on stderr (tqdm)."""
    if not enabled:
        yield from items
        return
    from tqdm import tqdm

    yield from tqdm(items, desc="loading landblocks", unit="lb", file=sys.stderr)


def _load_all(world: Any, ids: Iterable[int], progress: bool) -> tuple[int, int, list[str]]:
    """Load `ids` into `world`: (loaded, not in the dats, errors)."""
    from engine import DatError

    source = world.dat_source
    loaded = missing = 0
    errors: list[str] = []
    for lb_id in _progress(list(ids), progress):
        if not source.has_landblock(lb_id):
            missing += 1
            continue
        try:
            world.load_landblock(lb_id)
            loaded += 1
        except (DatError, ValueError) as e:  # a corrupt record: say which, go on with the rest
            errors.append(f"{lb_id:04X}: {e}")
    return loaded, missing, errors


def run_load_region(args: argparse.Namespace, out: TextIO | None = None) -> int:
    """`acphys load-region`: load every landblock of the rectangle the dats hold, then report."""
    from engine import DatError
    from engine import open_dat_world

    out = out if out is not None else sys.stdout
    ids = region_ids(args.corner1, args.corner2)
    cache_size = args.cache_size if args.cache_size is not None else len(ids)
    try:
        world = open_dat_world(args.dat_dir, cache_size=cache_size, indoor=False if args.terrain_only else None)
    except (DatError, ValueError) as e:
        print(f"acphys load-region: {e}", file=sys.stderr)
        return 1
    t0 = time.perf_counter()
    try:
        loaded, missing, errors = _load_all(world, ids, not args.no_progress)
    finally:
        if world.dat_source is not None:
            world.dat_source.close()
    seconds = time.perf_counter() - t0
    s = world.stats
    print(f"region {args.corner1:04X}..{args.corner2:04X}: {len(ids)} landblocks, {loaded} loaded,"
          f" {missing} not in the dats, {len(errors)} failed, in {seconds:.2f} s", file=out)  # fmt: skip
    print(f"  cache      {s['landblock_cache_size']} held of {s['landblock_cache_capacity']};"
          f" loads {s['landblock_loads']}, unloads {s['landblock_unloads']}", file=out)  # fmt: skip
    for line in errors[:20]:
        print(f"  error      {line}", file=out)
    if len(errors) > 20:
        print(f"  ...        {len(errors) - 20} more errors", file=out)
    return 1 if errors else 0
