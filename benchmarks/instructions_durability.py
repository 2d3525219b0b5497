"""Instructions per move of the column path with the state log under each `--state-sync` policy (callgrind).

The throughput shares of section 8 carry several per cent of this shared machine's noise; a count does
not. A child process builds the service core on the demo world with a stand-in bus, as
benchmarks/instructions_service.py does, registers the batch workload's 100 movers and handles column requests of
100 offset moves round after round (decode, checks, `run_columns` with its `commit`, `reply_message`):
without `--state`, and with a state log (service/persistence/journal.py) under every-second, always and never.
Two runs that differ only in the number of rounds give the instructions per move as their difference,
start-up cancelled out.

Threads are counted apart (`--separate-threads=yes`): the engine thread (the main one here) and the log's
own thread. The log's thread gets its periodic write once, when the rounds are done (woken by hand, its
interval an hour: the count must not depend on how many seconds the child took under valgrind), then
`close` syncs what is left. Under `always` everything is the engine thread's: each request's framing,
write and fdatasync before its reply. A syscall counts as the instructions that prepare it, never the
disk's time nor the kernel's (valgrind counts user space only). PYTHONHASHSEED is fixed and OpenBLAS kept
to one thread, so a count is the same every run.

Run alone: `python3 -m benchmarks.instructions_durability [ROOT]` (ROOT: a checkout with a compiled
engine in its .venv; default this one). Part of section 8 (benchmarks/bench_durability.py).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from . import common

__all__ = ["count_policies", "CONFIGS", "ROUNDS", "MOVES_PER_ROUND", "WATCHED", "unavailable", "section_lines",
           "target_words"]

CONFIGS = ("none", "every-second", "always", "never")
#: rounds of the short and the long run; their difference is what is counted
ROUNDS = (4, 14)
#: each round is two requests of 100 moves (the batch workload's two client processes)
MOVES_PER_ROUND = 200
CHILD_TIMEOUT_S = 1800.0

_CHILD = """
import json, sys, tempfile, threading, time
from pathlib import Path
paths, bench_root, rounds, policy = json.loads(sys.argv[1]), sys.argv[2], int(sys.argv[3]), sys.argv[4]
sys.path[:0] = paths
import engine.world.batch as batch
from engine import load_scene
from service import heap
from service.column_moves import reply_message, run_columns
from service.protocol.column_request import parse_column_request
from service.core import ServiceCore
from service.ownership import Ownership
from service.protocol.requests import RegisterRequest, decode_envelope
from service.stats import ServiceStats
import clients.demo.world  # the measured checkout's client library, not the harness checkout's
sys.path.insert(0, bench_root)
from benchmarks.bench_batches import _column_request_bytes, batch_spots, demo_scene
from benchmarks.scenes import PLAYER
from benchmarks.standins import SilentBus

world = load_scene(str(demo_scene()))
core = ServiceCore(world, SilentBus(), ownership=Ownership(), instance="count", stats=ServiceStats())
ids = [core.register(RegisterRequest(None, PLAYER, pos, plane, cell))["state"]["id"]
       for pos, plane, cell in batch_spots(world)]
half = len(ids) // 2
requests = [_column_request_bytes(ids[:half]), _column_request_bytes(ids[half:])]
journal = None
if policy != "none":
    from service.persistence.journal import Journal
    from service.persistence.journal_records import MoverLog
    tmp = tempfile.mkdtemp(prefix="acphys-count-")
    # an hour's interval: the log's thread writes only when woken below, whatever the run's wall time
    journal = Journal(Path(tmp) / "movers.state", 0, policy, interval=3600.0)
    written = threading.Event()
    write = journal._write
    def counted_write(sync, write=write, written=written):
        write(sync)
        written.set()
    journal._write = counted_write
    core.attach_log(MoverLog(journal))
heap.tune()
heap.settle()  # as a serving process does after loading its world
served = 0
for _ in range(rounds):
    for payload in requests:
        out, _ = run_columns(core, parse_column_request(decode_envelope(payload)), time.monotonic())
        reply_message(out)
        served += out.n - len(out.errors)
size = 0
if journal is not None:
    if journal._thread is not None:  # the log thread's write of what waits, as its second's tick would
        written.clear()
        journal._wake.set()
        written.wait()
    journal.close()
    size = journal.path.stat().st_size
import service.persistence.journal as journal_module
print("RESULT " + json.dumps({"moves": served, "log_bytes": size, "main": threading.get_native_id(),
                              "compiled": not batch.__file__.endswith(".py"),
                              "crc32": getattr(getattr(journal_module, "crc32", None), "__module__", "zlib")}))
"""

_TOTALS = re.compile(r"^(?:totals|summary):\s+(\d+)\s*$", re.MULTILINE)
#: the functions whose instructions (with their callees') are given apart: the record's two per-byte costs. The
#: log's crc32 is ISA-L's where python-isal is installed (service/persistence/journal.py), else zlib's: both are watched, one
#: of them counts. isal's wheel is stripped, so its crc is watched through the module function Python calls,
#: isal_zlib_crc32 (with its argument handling, a few hundred instructions a call: a call per record part, not
#: per move); zlib's through crc32_z, the bare loop
WATCHED = {"crc32_z": "crc32 (zlib)", "isal_zlib_crc32": "crc32 (ISA-L)",
           "CPyDef_batch___write_mover_state": "write_mover_state (run_batch)"}
#: the watched functions that are the log's crc32
CRC_WATCHED = ("crc32_z", "isal_zlib_crc32")
_ANNOTATED = re.compile(r"^\s*([\d,]+) \([^)]*\)\s+\S*?:(\w+) \[", re.MULTILINE)


def unavailable(python: str, paths: list[Path]) -> str | None:
    """Why the counts cannot be made with `python` importing from `paths` first, or None."""
    if shutil.which("valgrind") is None:
        return "valgrind is not installed (Debian: apt-get install valgrind)"
    probe = subprocess.run([python, "-c", "import sys; sys.path[:0] = sys.argv[1:]; import engine.world.batch as b; "
                            "print(b.__file__)", *map(str, paths)], cwd=paths[0], env=_env(),
                           capture_output=True, text=True, timeout=120, check=False)
    if probe.returncode != 0 or probe.stdout.strip().endswith(".py"):
        return f"{python}'s engine is not compiled (counts of interpreted code would say nothing of the build)"
    return None


def _env() -> dict[str, str]:
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1", PYTHONHASHSEED="0", OPENBLAS_NUM_THREADS="1")
    env.pop("PYTHONPATH", None)
    return env


def _run(python: str, paths: list[Path], rounds: int, policy: str) -> dict[str, Any]:
    """One counted child: its RESULT and the instructions of each thread, the engine (main) thread first."""
    import json

    with tempfile.TemporaryDirectory(prefix="acphys-callgrind-") as tmp:
        out = Path(tmp) / "callgrind.out"
        cmd = ["valgrind", "--tool=callgrind", "--separate-threads=yes", f"--callgrind-out-file={out}", python,
               "-c", _CHILD, json.dumps([str(p) for p in paths]), str(common.ROOT), str(rounds), policy]
        p = subprocess.run(cmd, cwd=paths[0], env=_env(), capture_output=True, text=True, timeout=CHILD_TIMEOUT_S,
                           check=False)
        lines = [ln for ln in p.stdout.splitlines() if ln.startswith("RESULT ")]
        files = sorted(Path(tmp).glob("callgrind.out-*"))
        if p.returncode != 0 or not lines or not files:
            raise RuntimeError(f"callgrind run of {policy}, {rounds} rounds failed ({p.returncode}): {p.stderr[-800:]}")
        result: dict[str, Any] = json.loads(lines[-1][7:])
        threads: list[int] = []
        watched = dict.fromkeys(WATCHED, 0)
        for f in files:  # one file a thread, the main thread's first (callgrind numbers threads from 1)
            text = f.read_text()
            m = _TOTALS.search(text)
            if m is None:
                raise RuntimeError(f"no totals line in {f.name}")
            threads.append(int(m.group(1)))
            annotated = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--auto=no", "--threshold=100",
                                        str(f)], capture_output=True, text=True, timeout=600, check=False).stdout
            for count, name in _ANNOTATED.findall(annotated):
                if name in watched:
                    watched[name] += int(count.replace(",", ""))
        result["threads"] = threads
        result["watched"] = watched
        return result


def _per_move(low: int, high: int) -> float:
    return (high - low) / ((ROUNDS[1] - ROUNDS[0]) * MOVES_PER_ROUND)


def count_policies(python: str, paths: list[Path]) -> dict[str, Any]:
    """Instructions per move of the column path under each configuration, on the engine thread and on every
    other thread (the log's): `python` importing the engine, the service and the client library from `paths`
    first (a checkout; or a compiled engine copy, then this checkout), this checkout's harness."""
    jobs = [(cfg, rounds) for cfg in CONFIGS for rounds in ROUNDS]
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        runs = dict(zip(jobs, pool.map(lambda job: _run(python, paths, job[1], job[0]), jobs)))
    rows: dict[str, Any] = {}
    for cfg in CONFIGS:
        low, high = runs[(cfg, ROUNDS[0])], runs[(cfg, ROUNDS[1])]
        for r in (low, high):
            if r["moves"] != (ROUNDS[0] if r is low else ROUNDS[1]) * MOVES_PER_ROUND:
                raise RuntimeError(f"{cfg}: the column path resolved {r['moves']} moves")
            if not r["compiled"]:
                raise RuntimeError(f"{paths[0]}: its engine is not compiled")
        engine = _per_move(low["threads"][0], high["threads"][0])
        others = _per_move(sum(low["threads"][1:]), sum(high["threads"][1:]))
        rows[cfg] = {"engine_thread": engine, "other_threads": others, "whole": engine + others,
                     "watched": {name: _per_move(low["watched"][name], high["watched"][name]) for name in WATCHED},
                     "log_bytes_per_move": (high["log_bytes"] - low["log_bytes"])
                     / ((ROUNDS[1] - ROUNDS[0]) * MOVES_PER_ROUND),
                     "crc32": high.get("crc32", "zlib")}
    base = rows["none"]
    for cfg in CONFIGS[1:]:
        row = rows[cfg]
        row["log_engine_thread"] = row["engine_thread"] - base["engine_thread"]
        row["log_whole"] = row["whole"] - base["whole"]
        row["log_share_engine_thread"] = row["log_engine_thread"] / base["engine_thread"]
        row["log_share_whole"] = row["log_whole"] / base["whole"]
    return {"rows": rows, "rounds": list(ROUNDS), "moves_per_round": MOVES_PER_ROUND,
            "commit": common.short_commit(paths[-1]), "crc32": rows["every-second"]["crc32"]}


def target_words(counted: dict[str, Any], inprocess: dict[str, Any]) -> str:
    """What the counts say of the every-second target, for section 8's list of targets."""
    row = counted.get("rows", {}).get("every-second")
    if not row:
        return "(No instruction count in this run: " + str(counted.get("unavailable", "not made")) + ".)"
    crc = "ISA-L's" if str(counted.get("crc32", "zlib")).startswith("isal") else "zlib's"
    return (f"Counted instead of timed (callgrind, the same in every run; commit {counted.get('commit')}, the log's "
            f"crc32 {crc}), the log under every-second adds "
            f"{row['log_whole']:,.0f} instructions to the {counted['rows']['none']['whole']:,.0f} of a column move "
            f"without it: {100 * row['log_share_whole']:.1f} % ({row['log_engine_thread']:,.0f} on the engine thread, "
            f"{100 * row['log_share_engine_thread']:.1f} %, and {row['other_threads']:,.0f} on the log's own thread, "
            "which releases the GIL for its checksums and writes). "
            + ("Within 5 % by that count" if row["log_share_whole"] <= 0.05 else "Over 5 % by that count")
            + ", which leaves out the kernel's side (the writes' copies into the page cache, the fdatasync) and cache "
            "misses: the service's CPU per move in the table below has them, blurred by the machine's load.")


def section_lines(counted: dict[str, Any]) -> list[str]:
    """Section 8's table of the counts."""
    if not counted:
        return []
    if "unavailable" in counted:
        return ["", f"Instructions per move not counted: {counted['unavailable']}."]
    rows = counted["rows"]
    out = ["", (f"Instructions per move of the column path (benchmarks/instructions_durability.py, commit "
                f"{counted.get('commit')}): the service core on the demo world with a stand-in bus runs column "
                f"batches of 100 offset moves as the batch workload sends them (decode, `run_columns` with its commit, "
                f"`reply_message`), counted by callgrind as the difference of a {counted['rounds'][0]}-round and a "
                f"{counted['rounds'][1]}-round run, each thread apart. The log's thread writes once when the rounds are "
                "done, as its second's tick would; under `always` each request's write and fdatasync are the engine "
                "thread's. A syscall counts only the instructions that make it (valgrind sees user space only: not "
                "the kernel's copy, not the disk)."), "",
           "| `--state-sync` | engine thread | log's thread | in all | the log's share (engine thread / all) | "
           + " | ".join(WATCHED.values()) + " |",
           "|---|---:|---:|---:|---:|" + "---:|" * len(WATCHED)]
    for cfg in CONFIGS:
        row = rows.get(cfg)
        if row is None:
            continue
        share = ("" if cfg == "none" else f"{100 * row['log_share_engine_thread']:.1f} % / "
                 f"{100 * row['log_share_whole']:.1f} %")
        name = "no `--state`" if cfg == "none" else f"`{cfg}`"
        watched = " | ".join(f"{row.get('watched', {}).get(k, float('nan')):,.0f}" for k in WATCHED)
        out.append(f"| {name} | {row['engine_thread']:,.0f} | {row['other_threads']:,.0f} | {row['whole']:,.0f} | "
                   f"{share} | {watched} |")
    es = rows.get("every-second")
    if es:
        crc = sum(es.get("watched", {}).get(k, 0.0) for k in CRC_WATCHED)
        state = es.get("watched", {}).get("CPyDef_batch___write_mover_state", 0.0)
        rest = es["log_whole"] - crc - state
        per_byte = crc / max(es["log_bytes_per_move"], 1)
        whose = (f"ISA-L's crc32 (python-isal) over those bytes (about {per_byte:.1f} a byte, its call's argument "
                 "handling included: it folds with carry-less multiplication, as far as valgrind's model of the "
                 "processor lets it)" if es.get("crc32", "zlib").startswith("isal") else
                 f"zlib's crc32 over those bytes (about {per_byte:.1f} a byte: zlib 1.2.13, as Debian ships it, "
                 "computes it without carry-less multiplication; python-isal was not installed)")
        out += ["", (f"What bounds the log's cost: every move writes its mover's whole state (224 bytes, with its id "
                     f"and seq 240) and checksums it. Of the {es['log_whole']:,.0f} instructions the log adds under "
                     f"every-second, {crc:,.0f} are {whose} "
                     f"and {state:,.0f} the engine writing the state beside its row; the other "
                     f"{rest:,.0f} are the copies and the Python around them (taking the rows' bytes, packing the "
                     "seqs, queuing the record, framing it). callgrind counts a `rep movsb` copy once per byte, "
                     "so the copies weigh more here than in time.")]
    return out


def python_of(root: Path) -> str:
    venv = root / ".venv" / "bin" / "python"
    return str(venv) if venv.exists() else "python3"


if __name__ == "__main__":
    import json
    import sys

    where = Path(sys.argv[1]).resolve() if len(sys.argv) > 1 else common.ROOT
    py = python_of(where)
    why = unavailable(py, [where])
    if why is not None:
        raise SystemExit(why)
    counted = count_policies(py, [where])
    for name, row in counted["rows"].items():
        extra = (f"; the log {row['log_engine_thread']:,.0f} on the engine thread "
                 f"({100 * row['log_share_engine_thread']:.1f} %), {row['log_whole']:,.0f} in all "
                 f"({100 * row['log_share_whole']:.1f} %)") if name != "none" else ""
        print(f"{name:13s} engine thread {row['engine_thread']:9,.0f}  other threads {row['other_threads']:7,.0f}"
              f"  per move{extra}")
    print(json.dumps(counted))
