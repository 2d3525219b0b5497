"""The interpreted and the compiled engine side by side, measured in the same run.

setup.py compiles the engine's hot modules with mypyc into .so files next to
the sources (`pip install -e .` does it). Whichever build the working tree
has, the other one is run here in a child process that imports a copy of the
engine:

- pure: benchmarks/out/pure/engine, the .py sources only (made on the fly);
- compiled: benchmarks/out/compiled/engine, built from a copy of the sources
  with the project's setup.py (`python3 -m benchmarks --build-compiled`, a
  few minutes; reused while the sources are unchanged).

The child checks that it imported what it should (no .so for pure; .so for
compiled) and prints one JSON line `VARIANT {...}`:

    python3 -m benchmarks.pure pure|compiled engine|error [--quick] [--error-cases N] [--base-records F]
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

from . import common

ROOTS = {"pure": common.OUT / "pure", "compiled": common.OUT / "compiled"}


def _sources_digest(engine_dir: Path) -> str:
    h = hashlib.sha256()
    for p in sorted(engine_dir.rglob("*.py")):
        h.update(str(p.relative_to(engine_dir)).encode())
        h.update(p.read_bytes())
    return h.hexdigest()


def _copy_sources(dst_root: Path) -> None:
    dst = dst_root / "engine"
    if dst.exists():
        shutil.rmtree(dst)
    dst_root.mkdir(parents=True, exist_ok=True)
    shutil.copytree(common.ROOT / "engine", dst,
                    ignore=shutil.ignore_patterns("*.so", "*.pyd", "__pycache__", "*.c", "build"))


def prepare_pure() -> Path:
    _copy_sources(ROOTS["pure"])
    return ROOTS["pure"]


def compiled_ready() -> bool:
    """A compiled copy exists and was built from the engine's current sources."""
    root = ROOTS["compiled"]
    stamp = root / "sources.sha256"
    return (stamp.exists() and any((root / "engine").rglob("*.so"))
            and stamp.read_text().strip() == _sources_digest(common.ROOT / "engine"))


def build_compiled(timeout: float = 1800.0) -> Path:
    """Compile a copy of the sources with the project's setup.py (mypyc) and keep the result in
    benchmarks/out/compiled. The build runs in a temporary directory outside the repository (mypy
    names modules after the directories above them), then engine/ and the shared native module
    are copied over."""
    import tempfile

    root = ROOTS["compiled"]
    if compiled_ready():
        return root
    with tempfile.TemporaryDirectory(prefix="acphys-compiled-") as tmp:
        work = Path(tmp)
        _copy_sources(work)
        shutil.copy2(common.ROOT / "setup.py", work / "setup.py")
        proc = subprocess.run([sys.executable, "setup.py", "build_ext", "--inplace"], cwd=work, capture_output=True,
                              text=True, timeout=timeout, check=False)
        if proc.returncode != 0 or not any((work / "engine").rglob("*.so")):
            raise RuntimeError(f"compiling the engine failed ({proc.returncode}): {proc.stderr[-2000:]}")
        if root.exists():
            shutil.rmtree(root)
        root.mkdir(parents=True)
        shutil.copytree(work / "engine", root / "engine", ignore=shutil.ignore_patterns("__pycache__", "*.c"))
        for native in work.glob("*__mypyc*"):
            if native.suffix in (".so", ".pyd"):
                shutil.copy2(native, root / native.name)
    (root / "sources.sha256").write_text(_sources_digest(common.ROOT / "engine"))
    return root


def run_child(variant: str, section: str, args: list[str], timeout: float = 3600.0) -> dict[str, Any]:
    root = prepare_pure() if variant == "pure" else build_compiled()
    env = dict(os.environ)
    # the copy first, then the repo for `benchmarks` itself (its engine is shadowed by the copy)
    env["PYTHONPATH"] = os.pathsep.join([str(root), str(common.ROOT)])
    env["PYTHONUNBUFFERED"] = "1"
    proc = subprocess.run([sys.executable, "-m", "benchmarks.pure", variant, section, *args], cwd=root, env=env,
                          capture_output=True, text=True, timeout=timeout, check=False)
    sys.stderr.write("".join(f"  [{variant}] {ln}\n" for ln in proc.stderr.splitlines()[-40:]))
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("VARIANT ")]
    if proc.returncode != 0 or not lines:
        raise RuntimeError(f"{variant} child failed ({proc.returncode}): {proc.stderr[-2000:]}")
    out = json.loads(lines[-1][len("VARIANT "):])
    out["kind"] = variant
    return out


def _child(argv: list[str]) -> None:
    import argparse

    import engine

    p = argparse.ArgumentParser()
    p.add_argument("variant", choices=["pure", "compiled"])
    p.add_argument("section", choices=["engine", "error"])
    p.add_argument("--quick", action="store_true")
    p.add_argument("--error-cases", type=int, default=None)
    p.add_argument("--base-records", default=None, help="JSON file of the main run's base records")
    a = p.parse_args(argv)
    compiled = common.compiled_modules()
    root = ROOTS[a.variant].resolve()
    if not str(Path(engine.__file__).resolve()).startswith(str(root)) or bool(compiled) != (a.variant == "compiled"):
        raise SystemExit(f"not the {a.variant} copy: engine from {engine.__file__}, compiled modules {compiled}")
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
    out["compiled_modules"] = compiled
    print("VARIANT " + json.dumps(out, default=lambda x: None), flush=True)


if __name__ == "__main__":
    _child(sys.argv[1:])
