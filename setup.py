"""Build hook: compile the engine's hot modules (and two of the service's) with mypyc.

The modules stay plain, typed Python; mypyc turns them into C extensions
that give the same answers several times faster. Set ACPHYS_COMPILE=0 to
install the pure-Python engine only (no compiler needed).
"""

from __future__ import annotations

import glob
import os
import sys

from setuptools import setup

# The per-move path: geometry, terrain, cells, BSP, objects, the transition
# and the mover. Loaders, formats and the World facade stay interpreted (they
# are not hot, and they use dynamic features mypyc does not compile).
HOT_PACKAGES = ("geometry", "terrain", "cells", "transition", "bsp", "objects")
NOT_COMPILED = {"engine/objects/setup.py"}
# The world's per-move part: the mover, its shadows, the move itself, the batch entry point and the
# MoveResult every move builds (types: a compiled dataclass is built and read natively).
WORLD_HOT = ("mover", "transient", "landblock", "shadows", "resolve", "rollback", "quantum", "moves", "batch", "rows",
             "types")
# Navigation's per-edge path: the walk that proves every edge and path, the graph that samples and links
# nodes, the search (a graph build walks some 70,000 edges a landblock; their glue is as hot as the moves)
NAVIGATION_HOT = ("walk", "graph", "search", "sampling")
# The service's per-move leaves: the State packer (generated from its declaration into a module for this,
# service/protocol/generate.py: compiled, it reads the engine's MoveResult natively) and the stats every
# request and move bumps. Callgrind, one move on a compiled clone: 15,190 -> 8,418 and 12,439 -> 6,544
# instructions. Both are leaves with no dynamic features; the rest of the service stays interpreted.
SERVICE_HOT = ["service/protocol/state_packer.py", "service/stats.py"]


def hot_modules() -> list[str]:
    # limits: the checks every move passes at the door; settings: read on every move (a compiled
    # class is read natively)
    mods = ["engine/constants.py", "engine/settings.py", "engine/limits.py"] + [f"engine/world/{name}.py" for name in WORLD_HOT]
    mods += [f"engine/navigation/{name}.py" for name in NAVIGATION_HOT]
    mods += SERVICE_HOT
    for pkg in HOT_PACKAGES:
        for path in sorted(glob.glob(f"engine/{pkg}/*.py")):
            if not path.endswith("__init__.py") and path not in NOT_COMPILED:
                mods.append(path)
    return mods


ext_modules = []
if os.environ.get("ACPHYS_COMPILE", "1") != "0":
    from mypyc.build import mypycify

    modules = hot_modules()
    # seen with `pip install -v` (pip hides a build's output otherwise; install.sh says it before pip runs)
    print(f"acphys: compiling {len(modules)} engine and service modules with mypyc: about 2 minutes on an idle 2-core machine "
          "(ACPHYS_COMPILE=0 installs the pure-Python engine instead)", file=sys.stderr, flush=True)
    ext_modules = mypycify(modules, opt_level="3")
    if sys.platform != "win32":
        # All compiled modules share one C file; without this, -fPIC keeps GCC and clang from inlining one
        # exported function into another (another library could interpose it), so small hot helpers such
        # as geometry.single.fl stay calls. CPython itself is built with it for the same reason.
        for ext in ext_modules:
            ext.extra_compile_args = [*ext.extra_compile_args, "-fno-semantic-interposition"]

setup(ext_modules=ext_modules)
