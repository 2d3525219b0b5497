"""Instructions per engine call on the reference traces, counted by valgrind's callgrind.

A noise-free complement to section 1's timings, and an A/B against another build. On this shared VM the
same compiled replay times 2.6 or 4.1 µs a move minutes apart; its instruction count does not move. A
count leaves out cache misses and allocation stalls, so it does not replace the timings: it tells
whether a change does less work, in one run, whatever else the machine is doing.

Each trace is replayed once, move by move as section 1 replays it (bench_engine.replay_trace), in a
child process under `valgrind --tool=callgrind --collect-atstart=no` with collection switched on only
inside the compiled engine's two entry points (World.move's move_checked and World.step's
step_checked): the interpreted harness, loading and start-up are not counted. Needs valgrind and a
compiled engine. `--against DIR` counts the compiled engine of another checkout (its .venv, its
engine) replayed by this checkout's harness, beside the working tree's; the children run side by side,
as counts do not depend on what else runs.
"""

from __future__ import annotations

import os
import shutil
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from . import common
from .bench_engine import TRACE_SCENES
from .callgrind import python_of as _python_of
from .callgrind import run_counted, totals_of
from .common import log

__all__ = ["run", "section", "totals_of", "ENTRY_SYMBOLS"]

#: the C symbols of the compiled entry points World.move and World.step call (mypyc's wrappers)
ENTRY_SYMBOLS = ("CPyPy_moves___move_checked", "CPyPy_moves___step_checked")
QUICK_TRACES = ("flat", "house")
QUICK_MOVES = 2000

# Run by the build's own python: the engine of `engine_root` is imported first, then this checkout's
# harness (it imports the engine already loaded, whichever checkout that came from).
_CHILD = """
import json, sys
engine_root, bench_root, name, max_moves = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
sys.path.insert(0, engine_root)
import engine
import engine.world.moves as moves
sys.path.insert(0, bench_root)
from benchmarks.bench_engine import replay_trace
from benchmarks.common import Deadline
calls = len(replay_trace(name, max_moves or None, Deadline(3600.0)))
print("RESULT " + json.dumps({"calls": calls, "compiled": not moves.__file__.endswith(".py"),
                              "engine": engine.__file__}))
"""

def _count(root: Path, name: str, max_moves: int) -> dict[str, Any]:
    """One trace replayed under callgrind with `root`'s engine: engine calls and instructions inside them."""
    result, counted = run_counted(_python_of(root), root, _CHILD, [str(common.ROOT), name, str(max_moves)],
                                  ["--collect-atstart=no", *(f"--toggle-collect={s}" for s in ENTRY_SYMBOLS)])
    if not result["compiled"]:
        raise RuntimeError(f"{root}: its engine is not compiled ({result['engine']}); counts of interpreted "
                           "code would say nothing about the compiled build")
    result["instructions"] = counted
    return result


def unavailable() -> str | None:
    """Why the section cannot run here, or None."""
    if shutil.which("valgrind") is None:
        return "valgrind is not installed (Debian: apt-get install valgrind)"
    if not common.compiled_modules():
        return "the working tree's engine is not compiled (sh install.sh, then run .venv/bin/python -m benchmarks)"
    return None


def run(quick: bool, against: Path | None = None) -> dict[str, Any]:
    why = unavailable()
    if why is not None:
        log(f"instructions: not measured: {why}")
        return {"unavailable": why}
    traces = QUICK_TRACES if quick else tuple(TRACE_SCENES)
    max_moves = QUICK_MOVES if quick else 0
    roots = [common.ROOT] + ([against.resolve()] if against is not None else [])
    jobs = [(root, name) for name in traces for root in roots]
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        counted = list(pool.map(lambda job: _count(job[0], job[1], max_moves), jobs))
    by_job = dict(zip(jobs, counted))
    rows = []
    for name in traces:
        mine = by_job[(common.ROOT, name)]
        row: dict[str, Any] = {"name": name, "calls": mine["calls"], "instructions": mine["instructions"],
                               "per_call": mine["instructions"] / mine["calls"]}
        if against is not None:
            other = by_job[(roots[1], name)]
            if other["calls"] != mine["calls"]:
                raise RuntimeError(f"{name}: {other['calls']} engine calls with {against}, {mine['calls']} here")
            row["against_per_call"] = other["instructions"] / other["calls"]
            row["ratio"] = row["per_call"] / row["against_per_call"]
        rows.append(row)
        log(f"instructions: {name:9s} {row['per_call']:9.0f} per engine call (n={row['calls']})"
            + (f"; against {row['against_per_call']:9.0f}: {row['ratio']:.2f}" if against is not None else ""))
    from .instructions_service import count_column_path

    column_path = [count_column_path(_python_of(root), root) for root in roots]
    for root, counted_path in zip(roots, column_path):
        log(f"instructions: the batch workload's column path ({root.name}) {counted_path['per_move']:9.0f} per move, "
            f"run_batch {counted_path['run_batch_per_move']:9.0f}, the rest {counted_path['rest_per_move']:9.0f}")
    from .instructions_single_move import count_single_move

    single_move = [count_single_move(_python_of(root), root) for root in roots]
    for root, counted_move in zip(roots, single_move):
        log(f"instructions: one move request handled ({root.name}) {counted_move['per_move']:9.0f} per move, "
            f"the service's own {counted_move['service_per_move']:9.0f}, the engine's {counted_move['engine_per_move']:9.0f}")
    from .instructions_client_move import count_client_move

    client_move = [count_client_move(_python_of(root), root) for root in roots]
    for root, counted_call in zip(roots, client_move):
        log(f"instructions: one Client.move in the client library ({root.name}) {counted_call['per_call']:9.0f} per call")
    from .instructions_round_trip import count_round_trip

    round_trip = [count_round_trip(_python_of(root), root) for root in roots]
    for root, counted_trip in zip(roots, round_trip):
        log(f"instructions: one move's round trip, whole stack ({root.name}): the bound {counted_trip['bound']:9.0f}, "
            f"the service asked raw {counted_trip['service_raw']:9.0f}, Client.move {counted_trip['client']:9.0f} "
            f"(+{counted_trip['client_over_bound']:.0f} over the bound)")
    return {"rows": rows, "against": str(against) if against is not None else None,
            "against_commit": common.short_commit(roots[1]) if against is not None else None,
            "symbols": list(ENTRY_SYMBOLS), "moves_each": max_moves or None, "column_path": column_path,
            "single_move": single_move, "client_move": client_move, "round_trip": round_trip}


def section(data: dict[str, Any], meta: str) -> list[str]:
    """The report's section (benchmarks/report.py); `meta` its line on how it was measured."""
    out = ["## 6. Instructions per engine call (callgrind)", "", meta, ""]
    if "unavailable" in data:
        return out + [f"Not measured: {data['unavailable']}.", ""]
    against = data.get("against")
    out += [("Each reference trace replayed once as section 1 replays it, under valgrind's callgrind, counting only "
             "the instructions inside the compiled engine's entry points (World.move's `move_checked`, World.step's "
             "`step_checked`): the same count in every run, whatever else the machine does, so it shows whether a "
             "change does less work where the timings above cannot tell. It leaves out cache misses and allocation "
             "stalls: it does not replace the timings.")
            + (f" Beside it, the compiled engine of `{against}` (commit {data.get('against_commit')}), replayed by "
               "the same harness." if against else ""), ""]
    if against:
        out += ["| trace | engine calls | instructions per call | the other build's | this / other |",
                "|---|---:|---:|---:|---:|"]
        out += [f"| {r['name']} | {r['calls']:,} | {r['per_call']:,.0f} | {r['against_per_call']:,.0f} | "
                f"{r['ratio']:.2f} |" for r in data["rows"]]
    else:
        out += ["| trace | engine calls | instructions per call |", "|---|---:|---:|"]
        out += [f"| {r['name']} | {r['calls']:,} | {r['per_call']:,.0f} |" for r in data["rows"]]
    return (out + _column_path_lines(data.get("column_path"), data.get("against_commit"))
            + _single_move_lines(data.get("single_move"), data.get("against_commit"))
            + _client_move_lines(data.get("client_move"), data.get("against_commit"))
            + _round_trip_lines(data.get("round_trip"), data.get("against_commit")))


def _column_path_lines(counts: list[dict[str, Any]] | None, against_commit: str | None) -> list[str]:
    """The service's column path on the batch workload (benchmarks/instructions_service.py)."""
    if not counts:
        return [""]
    rounds = counts[0]["rounds"]
    out = ["", ("The batch workload's column path in the service, instructions per move (benchmarks/instructions_service.py): "
                "the service core on the demo world with a stand-in bus handles the two client processes' column "
                "requests for the 100 movers (decode, checks, `run_columns`, `reply_message`: the query callback's "
                f"work but Zenoh's receive and reply), counted as the difference of a {rounds[0]}-round and a "
                f"{rounds[1]}-round run; \"run_batch\" counts only inside the engine's batch entry point, and the rest "
                "is the service's own work per move (with the freeing of the batch's results)."), "",
           *_count_table(("whole path", "run_batch", "the rest"), counts,
                         ("per_move", "run_batch_per_move", "rest_per_move"), against_commit)]
    return out + [""]


def _single_move_lines(counts: list[dict[str, Any]] | None, against_commit: str | None) -> list[str]:
    """One move request in the service's query callback (benchmarks/instructions_single_move.py)."""
    if not counts:
        return []
    moves = counts[0]["moves"]
    out = [("One move request handled, instructions per move (benchmarks/instructions_single_move.py): the "
            "service's move callback called with stand-in queries on the service benchmark's scene, one mover, "
            "nobody subscribed (Zenoh's receive, reply and matching status are not counted), as the difference "
            f"of a {moves[0]}-move and a {moves[1]}-move run; once with the engine replaced by a stand-in that "
            "answers the mover's current state (the service's own work) and once with the engine."), "",
           *_count_table(("whole callback", "the service's own", "the engine's"), counts,
                         ("per_move", "service_per_move", "engine_per_move"), against_commit)]
    return out + [""]


def _client_move_lines(counts: list[dict[str, Any]] | None, against_commit: str | None) -> list[str]:
    """One `Client.move` in the client library (benchmarks/instructions_client_move.py)."""
    if not counts:
        return []
    calls = counts[0]["calls"]
    out = [("One `Client.move` in the client library, instructions per call (benchmarks/instructions_client_move.py): "
            "a Client on a stand-in session that answers every request with a State as the service packs it (Zenoh's "
            "send and receive are not counted): the Move packed, its key found, the State read into a MoverState, "
            f"as the difference of a {calls[0]}-call and a {calls[1]}-call run."), "",
           *_count_table(("Client.move",), counts, ("per_call",), against_commit)]
    return out + [""]


def _round_trip_lines(counts: list[dict[str, Any]] | None, against_commit: str | None) -> list[str]:
    """One move's round trip, the whole stack in one process (benchmarks/instructions_round_trip.py)."""
    if not counts:
        return []
    trips = counts[0]["round_trips"]
    out = [("One move's round trip, instructions per round trip, the whole stack in one process "
            "(benchmarks/instructions_round_trip.py): both Zenoh sessions over loopback TCP, the server's callback "
            "and the client's call, every thread counted (the kernel's side is not), as the difference of a "
            f"{trips[0]}- and a {trips[1]}-round-trip run. The bound is the engine alone behind a bare queryable "
            "asked by a plain `get` (the timed bound), once on its key's text and once on the key declared; "
            "\"service, raw get\" is a service node asked the same request by a plain `get` on its declared "
            "`P/lb/XXYY/move` key, its reply read by msgpack; \"Client.move\" the same node asked by the client "
            "library (whose own share is below zero when it costs less than that plain `get` and msgpack: it "
            "reads the State with msgspec, building no dict). Zenoh's timers "
            "tick in wall time, so a count moves between runs (Client.move's by up to about 20,000 on this machine)."), "",
           *_count_table(("the bound", "the bound, key declared", "service, raw get", "Client.move",
                          "the service's own", "the client library's own", "Client.move over the bound"), counts,
                         ("bound", "bound_declared", "service_raw", "client", "service_over_bound",
                          "client_over_service_raw", "client_over_bound"), against_commit)]
    floors = [c for c in counts if "floor" in c]
    if len(floors) == len(counts):  # counts made before the floor was counted have no floor
        out += ["", ("The protocol's own floor in the same process (benchmarks/service_floor.py's lean handler "
                     "declared on the same node's session on a literal key: the service's reader, `World.move`, its "
                     "State packer, the reply; nothing else): \"floor, raw get\" asked as \"service, raw get\" is, "
                     "\"floor, least client\" by the floor's least client (the move map packed by msgspec, the key "
                     "declared, the first reply read by the client library's State reader). What the service's and "
                     "the client library's own work add beyond the protocol's is `Client.move` over the floor."), "",
                *_count_table(("floor, raw get", "floor, least client", "the floor over the bound",
                               "Client.move over the floor"), floors,
                              ("floor_raw", "floor", "floor_over_bound", "client_over_floor"), against_commit)]
    return out + [""]


def _count_table(headers: tuple[str, ...], counts: list[dict[str, Any]], keys: tuple[str, ...],
                 against_commit: str | None) -> list[str]:
    """A table of instruction counts, a row per build (this checkout, then the one compared against)."""
    out = ["| build | " + " | ".join(headers) + " |", "|---|" + "---:|" * len(headers)]
    for name, c in zip(["this checkout", f"commit {against_commit}"], counts):
        out.append(f"| {name} | " + " | ".join(f"{c[k]:,.0f}" for k in keys) + " |")
    return out
