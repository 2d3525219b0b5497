"""The pure-Python engine beside the compiled one, measured in the same run.

When the engine's hot modules are compiled (setup.py builds them with mypyc
into .so files next to the sources), the same sources can still run
interpreted. This copies the engine's .py files (no .so) to
benchmarks/out/pure/engine and runs a benchmark section in a child process
that imports that copy; the child checks that nothing compiled was loaded.

    python3 -m benchmarks.pure engine|error [--quick] [--error-cases N]

prints one JSON line `PURE {...}`.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

from . import common

PURE = common.OUT / "pure"


def prepare() -> Path:
    """A fresh copy of the engine's Python sources (and py.typed) under benchmarks/out/pure."""
    src = common.ROOT / "engine"
    dst = PURE / "engine"
    if dst.exists():
        shutil.rmtree(dst)
    shutil.copytree(src, dst, ignore=shutil.ignore_patterns("*.so", "*.pyd", "__pycache__", "*.c", "build"))
    return PURE


def run_child(section: str, args: list[str], timeout: float = 3600.0) -> dict[str, Any]:
    root = prepare()
    env = dict(os.environ)
    # the copy first, then the repo for `benchmarks` itself (its engine is shadowed by the copy)
    env["PYTHONPATH"] = os.pathsep.join([str(root), str(common.ROOT)])
    env["PYTHONUNBUFFERED"] = "1"
    proc = subprocess.run([sys.executable, "-m", "benchmarks.pure", section, *args], cwd=root, env=env,
                          capture_output=True, text=True, timeout=timeout, check=False)
    sys.stderr.write("".join(f"  [pure] {ln}\n" for ln in proc.stderr.splitlines()[-40:]))
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("PURE ")]
    if proc.returncode != 0 or not lines:
        raise RuntimeError(f"pure-Python child failed ({proc.returncode}): {proc.stderr[-2000:]}")
    return json.loads(lines[-1][5:])


def _child(argv: list[str]) -> None:
    import argparse

    import engine

    p = argparse.ArgumentParser()
    p.add_argument("section", choices=["engine", "error"])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--error-cases", type=int, default=None)
    p.add_argument("--base-records", default=None, help="JSON file of the compiled run's base records")
    a = p.parse_args(argv)
    compiled = common.compiled_modules()
    if compiled or not str(Path(engine.__file__).resolve()).startswith(str(PURE.resolve())):
        raise SystemExit(f"not the pure-Python copy: engine from {engine.__file__}, compiled {compiled}")
    if a.section == "engine":
        from . import bench_engine

        moves = 300 if a.quick else 2000
        out: dict[str, Any] = {"workloads": bench_engine.run_workloads(moves, 10.0 if a.quick else 60.0),
                               "traces": bench_engine.run_traces(300 if a.quick else 3000, 10.0 if a.quick else 60.0)}
    else:
        from . import bench_error

        base = json.loads(Path(a.base_records).read_text()) if a.base_records else None
        out = bench_error.run(a.quick, a.error_cases, only_reference=True, base_records=base)
        out.pop("base_records", None)
    out["engine_file"] = engine.__file__
    print("PURE " + json.dumps(out, default=lambda x: None), flush=True)


if __name__ == "__main__":
    _child(sys.argv[1:])
