"""The one entry point: `python3 -m benchmarks [--quick] [--only ...]`.

Runs the chosen benchmarks, stores their raw results in
docs/performance.json (committed beside the doc, so a section keeps its last
results when another section is re-run alone, on any machine), draws the plots into benchmarks/plots/ and rewrites
docs/performance.md from all stored sections.

Exit status 1 when the stress run found NaN/inf, fall-throughs, penetrations
or exceptions (their reproducers: benchmarks/out/stress_failures.json).
Bounded: the service part listens on 127.0.0.1 only and every loop ends after
a fixed count or time; the stress run stops at --stress-seconds.
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from . import common
from .common import log

SECTIONS = ("engine", "error", "service", "memory", "stress", "queries", "instructions", "navigation", "durability",
            "wire_decoding", "many_movers")


def _git_commit() -> str:
    try:
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "engine", "service", "clients"], check=False, cwd=common.ROOT,
                               capture_output=True, text=True, timeout=10).stdout.strip()
        return common.short_commit() + ("+uncommitted engine/service changes" if dirty else "")
    except Exception:  # noqa: BLE001
        return "unknown"


def _clean(x: Any) -> Any:
    """JSON without NaN/inf (null instead)."""
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {k: _clean(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_clean(v) for v in x]
    return x


def _variant(args: argparse.Namespace) -> str | None:
    """Which other build of the engine to measure beside the working tree's: 'pure' when the tree
    runs compiled modules, 'compiled' when it does not and a compiled copy is (or may be) built."""
    if args.no_variant:
        return None
    from . import pure

    if common.compiled_modules():
        return "pure"
    if args.build_compiled or pure.compiled_ready():
        return "compiled"
    return None


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python3 -m benchmarks", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help="small counts everywhere (a few minutes)")
    p.add_argument("--only", default=",".join(SECTIONS),
                   help="comma-separated subset of " + ",".join(SECTIONS) + " (default: all)")
    p.add_argument("--stress-moves", type=int, default=None,
                   help="moves in the stress run (default 1,000,000; 20,000 with --quick)")
    p.add_argument("--stress-seconds", type=float, default=None,
                   help="time budget of the stress run in seconds (default 3600; 120 with --quick)")
    p.add_argument("--stress-jobs", type=int, default=2, help="worker processes of the stress run (default 2)")
    p.add_argument("--stress-kinds-moves", type=int, default=None,
                   help="moves of the object-kinds fuzz in the stress run (default: as many as --stress-moves; "
                        "2,000 with --quick)")
    p.add_argument("--error-cases", type=int, default=None,
                   help="cases per reference trace in the error benchmark (default: all; 3 with --quick)")
    p.add_argument("--build-compiled", action="store_true",
                   help="when the working tree's engine is not compiled, build a compiled copy in benchmarks/out/compiled "
                        "with the project's setup.py (mypyc; minutes) and measure it beside the interpreted one")
    p.add_argument("--no-variant", action="store_true",
                   help="measure only the working tree's engine (no pure-Python or compiled copy beside it)")
    p.add_argument("--no-doc", action="store_true", help="do not rewrite docs/performance.md and the plots")
    p.add_argument("--against", type=Path, default=None, metavar="DIR",
                   help="the instructions section also counts the compiled engine of the checkout DIR (its .venv), "
                        "e.g. a clone of the commit before a change, for an A/B that machine noise cannot blur")
    args = p.parse_args(argv)
    only = [s.strip() for s in args.only.split(",") if s.strip()]
    bad = [s for s in only if s not in SECTIONS]
    if bad:
        p.error(f"unknown section(s) {', '.join(bad)}; choose from {', '.join(SECTIONS)}")

    common.OUT.mkdir(parents=True, exist_ok=True)
    results_path = common.DOC.with_suffix(".json")
    try:
        results = json.loads(results_path.read_text())
    except (OSError, ValueError):
        results = {}
    command = "python3 -m benchmarks " + " ".join(shlex.quote(a) for a in (argv if argv is not None else sys.argv[1:]))
    meta = {"command": command.strip(), "commit": _git_commit(), "started": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
            "machine": common.machine(), "quick": args.quick}

    for section in only:
        t0 = time.monotonic()
        log(f"== {section} ==")
        if section == "engine":
            from . import bench_engine

            data = bench_engine.run(args.quick)
            kind = _variant(args)
            if kind:
                from . import pure

                try:
                    data["variant"] = pure.run_child(kind, "engine", ["--quick"] if args.quick else [])
                except Exception as e:  # noqa: BLE001 - the doc says why instead
                    data["variant"] = {"kind": kind, "failed": f"{type(e).__name__}: {e}"}
        elif section == "error":
            from . import bench_error

            data = bench_error.run(args.quick, args.error_cases)
            records = data.pop("base_records")
            kind = _variant(args)
            if kind:
                from . import pure

                path = common.OUT / "base_records.json"
                path.write_text(json.dumps(records))
                child_args = ["--base-records", str(path)] + (["--quick"] if args.quick else [])
                if args.error_cases is not None:
                    child_args += ["--error-cases", str(args.error_cases)]
                try:
                    child = pure.run_child(kind, "error", child_args)
                    row = child["settings"][0]
                    row["name"] = f"{row['name']}, {kind}"
                    row["description"] = ("the same settings, the engine's sources interpreted (no compiled modules)"
                                          if kind == "pure" else
                                          "the same settings, the engine's hot modules compiled with mypyc (setup.py)"
                                          ) + ", in a child process"
                    data["settings"].append(row)
                except Exception as e:  # noqa: BLE001
                    data["variant_failed"] = f"{type(e).__name__}: {e}"
            data["pareto"] = bench_error.pareto(data["settings"])
        elif section == "service":
            from . import bench_service

            try:
                data = bench_service.run(args.quick)
            except Exception as e:  # noqa: BLE001 - the doc says why instead
                log(f"service benchmark failed: {type(e).__name__}: {e}")
                data = {"failed": f"{type(e).__name__}: {e}"}
            if _variant(args) == "compiled" and "failed" not in data:
                from . import pure

                log("service, again with the compiled engine copy:")
                try:
                    data["compiled"] = bench_service.run(args.quick, engine_root=pure.build_compiled())
                except Exception as e:  # noqa: BLE001
                    data["compiled"] = {"failed": f"{type(e).__name__}: {e}"}
        elif section == "queries":
            from . import bench_queries

            try:
                data = bench_queries.run(args.quick)
            except Exception as e:  # noqa: BLE001 - the doc says why instead
                data = {"failed": f"{type(e).__name__}: {e}"}
        elif section == "durability":
            from . import bench_durability

            try:
                root = None
                if _variant(args) == "compiled":  # the working tree's engine is interpreted: the compiled copy's
                    from . import pure

                    root = pure.build_compiled()
                data = bench_durability.run(args.quick, engine_root=root)
            except Exception as e:  # noqa: BLE001 - the doc says why instead
                log(f"durability benchmark failed: {type(e).__name__}: {e}")
                data = {"failed": f"{type(e).__name__}: {e}"}
        elif section == "navigation":
            from . import bench_navigation

            try:
                data = bench_navigation.run(args.quick)
            except Exception as e:  # noqa: BLE001 - the doc says why instead
                log(f"navigation benchmark failed: {type(e).__name__}: {e}")
                data = {"failed": f"{type(e).__name__}: {e}"}
        elif section == "instructions":
            from . import bench_instructions

            try:
                data = bench_instructions.run(args.quick, args.against)
            except Exception as e:  # noqa: BLE001 - the doc says why instead
                log(f"instructions benchmark failed: {type(e).__name__}: {e}")
                data = {"unavailable": f"the run failed: {type(e).__name__}: {e}"}
        elif section == "wire_decoding":
            from . import bench_wire_decoding

            data = bench_wire_decoding.run(args.quick)
            if "skipped" in data and "skipped" not in results.get(section, {"skipped": ""}):
                # without msgspec only the service's half runs: the stored comparison is kept
                log(f"wire decoding: {data['skipped']}; the stored comparison is kept")
                continue
        elif section == "many_movers":
            from . import bench_many_movers

            data = bench_many_movers.run(args.quick)
        elif section == "memory":
            from . import bench_memory

            data = bench_memory.run(args.quick)
        else:
            from . import stress

            moves = args.stress_moves if args.stress_moves is not None else (20000 if args.quick else 1_000_000)
            seconds = args.stress_seconds if args.stress_seconds is not None else (120.0 if args.quick else 3600.0)
            kinds = args.stress_kinds_moves if args.stress_kinds_moves is not None else (2000 if args.quick else moves)
            data = stress.run(moves, seconds, jobs=args.stress_jobs, kinds_moves=kinds)
            (common.OUT / "stress_failures.json").write_text(json.dumps(_clean(
                [dict(f, scenario=s["scenario"]) for s in data["scenarios"] for f in s["failures"]]), indent=1))
        data["meta"] = dict(meta, seconds=time.monotonic() - t0)
        results[section] = _clean(data)
        results_path.write_text(json.dumps(results, indent=1) + "\n")
        log(f"== {section} done in {time.monotonic() - t0:.0f} s ==")

    if not args.no_doc:
        from . import report

        report.write(results)
        log(f"wrote {common.DOC.relative_to(common.ROOT)} and plots in benchmarks/plots/")
    stress_bad = results.get("stress", {}).get("totals", {})
    from .stress import FAILURE_COUNTS

    return 1 if "stress" in only and any(stress_bad.get(k) for k in FAILURE_COUNTS) else 0
