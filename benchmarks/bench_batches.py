"""The batch workload: the service against the engine in process, on the same movers and moves.

100 player movers one every 8 m on the demo world, walking +-0.25 m and back, sent by two client
processes in batches of 100 through the map batch and the column batch (by the client library, and as
the column request's bytes in raw Zenoh gets: the clients its target is read with); beside it World.move and the
engine's batch entry point (run_batch) on the same movers in a process of their own, and the bound of
any service on this bus: the engine behind a bare Zenoh queryable, measured in rounds and, for the
raw-client form's target, in half-second windows paired with the bound's. Run by `python3 -m benchmarks
--only service` (benchmarks/bench_service.py); its children are this module's `batch-engine`,
`batch-worker`, `batch-paired` and `batch-bare` roles.
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from . import common
from .service_harness import Child, child_env, collect_reports, demo_scene, free_port, stop_event
from .common import log

__all__ = ["batch_workload", "batch_spots", "paired_raw_columns", "window_targets", "pair_ratios", "BATCH_MOVERS",
           "BATCH_STEP"]


# -- the batch workload: the map and the column form against the engine in process ----------------------
#: 100 player movers one every 8 m on the demo world, walking +-0.25 m; each of the two client processes
#: moves its 50 in batches of 100 (every mover out and back)
BATCH_MOVERS = 100


BATCH_SPACING = 8.0


BATCH_STEP = 0.25


BATCH_PROCESSES = 2


BATCH_FORMS = {
    "maps": "Client.move_many_maps: the map batch, entries as decoded maps",
    "columns": "Client.move_batch: the column batch, results as numpy arrays",
    "columns, raw clients": "the column batch as raw Zenoh gets of the bytes Client.move_batch sends, each reply "
                            "decoded with msgpack and its error list read: the clients the target is read with, and "
                            "the bound's",
}
#: the form whose clients are the bound's (raw Zenoh gets): the figure the service's 0.8 target is read from
RAW_COLUMNS_FORM = "columns, raw clients"

#: the bound beside the service: a bare Zenoh queryable whose only work per request is the engine's batch
BARE_FORM = "engine behind a bare queryable"
BARE_KEY = "acphys-bench/batches/bare"
#: the paired measurement of the raw-client form against the bound (benchmarks/batches_paired.py): 60 windows
#: of half a second, 30 pairs
PAIRED_WINDOW_S = 0.5
PAIRED_WINDOWS = 60


def batch_spots(world: Any) -> list[tuple[Any, Any, int]]:
    """(position on the ground, its contact plane, cell) of every mover: a 10 x 10 grid 8 m apart."""
    from clients.demo.world import global_to_cell
    from engine.geometry import Plane, Position, Vec3

    out = []
    side = int(round(BATCH_MOVERS ** 0.5))
    for k in range(BATCH_MOVERS):
        gx, gy = 100.0 + BATCH_SPACING * (k % side), 100.0 + BATCH_SPACING * (k // side)
        cell, x, y = global_to_cell(gx, gy)
        z = world.terrain_height(cell, x, y)
        n = world.landblocks[cell >> 16].terrain.normal_at(x, y)
        out.append((Position.at(cell, Vec3(x, y, z)), Plane(n, -n.dot(Vec3(x, y, z))), cell))
    return out


def batch_engine_rate(seconds: float) -> dict[str, Any]:
    """World.move on the same movers in this process: the rate the service is measured against; beside it
    the engine's batch entry point (engine.world.batch.run_batch) on the same moves in batches of 100."""
    from engine import load_scene
    from engine.geometry import Vec3
    from engine.world.batch import OFFSET, BatchRows, run_batch

    from .scenes import PLAYER

    world = load_scene(str(demo_scene()))
    ids = [world.add_mover(PLAYER, pos, plane, cell) for pos, plane, cell in batch_spots(world)]
    out, back = Vec3(BATCH_STEP, 0.0, 0.0), Vec3(-BATCH_STEP, 0.0, 0.0)

    def one_by_one() -> int:
        for offset in (out, back):
            for mid in ids:
                world.move(mid, world.mover(mid).position.moved(offset))
        return 2 * len(ids)

    batches = _share_batches(world, ids)  # as the clients send them

    def batched() -> int:
        for movers, vectors in batches:
            run_batch(world.landscape, movers, OFFSET, vectors, BatchRows())
        return 2 * len(ids)

    def rate(run: Any) -> dict[str, Any]:
        run()  # warm: every mover's cells looked up once, as the service's are before timing
        moves = 0
        t0, cpu0 = time.perf_counter(), time.process_time()
        end = t0 + seconds
        while time.perf_counter() < end:
            moves += run()
        elapsed, cpu = time.perf_counter() - t0, time.process_time() - cpu0
        return {"moves": moves, "seconds": elapsed, "moves_per_s": moves / elapsed,
                "cpu_us_per_move": cpu / moves * 1e6}

    row = rate(one_by_one)
    row["run_batch"] = rate(batched)
    return row


def _share_batches(world: Any, ids: list[int]) -> list[tuple[list[Any], list[float]]]:
    """Each client process's batch as run_batch takes it: every mover of its share out, then back."""
    share = len(ids) // BATCH_PROCESSES
    batches = []
    for k in range(BATCH_PROCESSES):
        movers = [world.mover(mid) for mid in ids[k * share:(k + 1) * share]]
        batches.append((movers + movers, [BATCH_STEP, 0.0, 0.0] * share + [-BATCH_STEP, 0.0, 0.0] * share))
    return batches


def _column_request_bytes(ids: list[int]) -> bytes:
    """A column request moving each of `ids` +0.25 m then -0.25 m, as Client.move_batch packs it."""
    import numpy as np

    from service.protocol.columns import REQUEST_COLUMNS, pack_columns
    from service.protocol.frames import pack

    offsets = np.zeros((2 * len(ids), 3))
    offsets[:len(ids), 0], offsets[len(ids):, 0] = BATCH_STEP, -BATCH_STEP
    return pack({"kind": "offset", "columns": pack_columns(REQUEST_COLUMNS, {
        "id": np.array(ids + ids, dtype=np.uint64), "offset": offsets})})


def _column_reply_size(n: int) -> int:
    """The bytes of a column reply of n items with no errors and no collisions."""
    import numpy as np

    from service.protocol.columns import REPLY_COLUMNS, pack_columns
    from service.protocol.frames import pack

    cols = pack_columns(REPLY_COLUMNS, {c.name: np.zeros((n,) if c.width == 1 else (n, c.width)) for c in REPLY_COLUMNS})
    cols["collide_ids"] = b""
    return len(pack({"n": n, "columns": cols, "errors": []}))


def batch_bare_main(endpoint: str) -> None:
    """The bound of any service on this bus: a bare Zenoh queryable that, for each request on
    `BARE_KEY/<client index>`, runs that client's batch through run_batch (nothing decoded, checked or
    encoded) and answers with as many bytes as the service's column reply; until SIGINT/SIGTERM."""

    import zenoh

    from engine import load_scene
    from engine.world.batch import OFFSET, BatchRows, run_batch
    from service.bus.zconfig import make_config

    from .scenes import PLAYER

    world = load_scene(str(demo_scene()))
    batches = _share_batches(world, [world.add_mover(PLAYER, pos, plane, cell) for pos, plane, cell in batch_spots(world)])
    reply = bytes(_column_reply_size(len(batches[0][0])))
    stop = stop_event()
    session = zenoh.open(make_config(listen=[endpoint]))

    def answer(query: Any) -> None:
        movers, vectors = batches[int(str(query.key_expr).rsplit("/", 1)[1])]
        run_batch(world.landscape, movers, OFFSET, vectors, BatchRows())
        query.reply(query.key_expr, reply)

    queryable = session.declare_queryable(f"{BARE_KEY}/*", answer)
    print("bare queryable ready", flush=True)
    stop.wait()
    queryable.undeclare()
    session.close()


def _bare_worker(endpoint: str, index: int, start_at: float, seconds: float) -> dict[str, Any]:
    """Raw gets of this process's column request to the bare queryable, the replies read as bytes only."""
    import zenoh

    from service.bus.zconfig import make_config

    share = BATCH_MOVERS // BATCH_PROCESSES
    payload = _column_request_bytes(list(range(index * share + 1, (index + 1) * share + 1)))
    session = zenoh.open(make_config(connect=[endpoint]))
    try:
        moves, errors, elapsed, cpu = _raw_gets(session, zenoh.KeyExpr(f"{BARE_KEY}/{index}"), payload, 2 * share,
                                                start_at, seconds, lambda reply: 0 if reply else 2 * share)
    finally:
        session.close()
    return {"index": index, "moves": moves, "errors": errors, "seconds": elapsed, "cpu_seconds": cpu}


def _raw_gets(session: Any, key: Any, payload: bytes, items: int, start_at: float, seconds: float,
              failed: Any) -> tuple[int, int, float, float]:
    """Raw gets of `payload`, a request of `items` moves, on `key` from `start_at` until `seconds` have
    passed; `failed(reply bytes)` says how many of the items a reply failed (an unanswered request fails
    them all): (moves, errors, seconds, CPU seconds)."""
    time.sleep(max(0.0, start_at - time.time()))
    cpu0 = time.process_time()
    end = time.monotonic() + seconds
    moves = errors = 0
    while time.monotonic() < end:
        failures = items
        for reply in session.get(key, payload=payload, timeout=30.0):
            if reply.ok is not None:
                failures = failed(reply.ok.payload.to_bytes())
        errors += failures
        moves += items
    return moves, errors, seconds + (time.monotonic() - end), time.process_time() - cpu0


def _raw_column_worker(c: Any, ids: list[int], start_at: float, seconds: float) -> tuple[int, int, float, float]:
    """Raw gets of this process's column request to the service (the bytes Client.move_batch sends for
    these movers), each reply decoded with msgpack and its `errors` counted: (moves, errors, seconds, CPU
    seconds)."""
    import msgpack
    import zenoh

    key = zenoh.KeyExpr(c.keys.move(c.landblock_of(ids[0])))
    if any(c.landblock_of(mid) != c.landblock_of(ids[0]) for mid in ids):
        raise RuntimeError("a share's movers are not in one landblock: one raw request cannot reach them all")
    payload = _column_request_bytes(ids)
    items = 2 * len(ids)

    def failed(reply: bytes) -> int:
        msg = msgpack.unpackb(reply)
        return len(msg.get("errors") or ()) if msg.get("n") == items else items

    return _raw_gets(c.session, key, payload, items, start_at, seconds, failed)


def batch_worker_main(endpoint: str, index: int, start_at: float, seconds: float, form: str) -> None:
    """Register this process's share of the grid, then send batches of 100 (each mover +0.25 m then -0.25 m)
    in `form` until `seconds` have passed; print a JSON report."""
    import numpy as np

    from clients import Client, Move
    from engine import load_scene

    from .scenes import PLAYER

    if form == BARE_FORM:
        print("RESULT " + json.dumps(_bare_worker(endpoint, index, start_at, seconds)), flush=True)
        return
    share = BATCH_MOVERS // BATCH_PROCESSES
    spots = batch_spots(load_scene(str(demo_scene())))[index * share:(index + 1) * share]
    with Client([endpoint], timeout=30.0) as c:
        ids = [c.register(PLAYER, pos, contact_plane=plane, contact_plane_cell=cell).id for pos, plane, cell in spots]
        batch_ids = np.array(ids + ids, dtype=np.uint64)
        offsets = np.zeros((2 * share, 3))
        offsets[:share, 0], offsets[share:, 0] = BATCH_STEP, -BATCH_STEP
        map_moves = [Move(int(i), offset=(o[0], o[1], o[2])) for i, o in zip(batch_ids.tolist(), offsets.tolist())]
        if form == RAW_COLUMNS_FORM:
            moves, errors, elapsed, cpu = _raw_column_worker(c, ids, start_at, seconds)
            for mid in ids:
                c.remove(mid)
            print("RESULT " + json.dumps({"index": index, "moves": moves, "errors": errors, "seconds": elapsed,
                                           "cpu_seconds": cpu}), flush=True)
            return
        time.sleep(max(0.0, start_at - time.time()))
        cpu0 = time.process_time()
        end = time.monotonic() + seconds
        moves = errors = 0
        while time.monotonic() < end:
            if form == "columns":
                errors += len(c.move_batch(batch_ids, offsets=offsets).errors)
            else:
                errors += sum(1 for e in c.move_many_maps(map_moves) if not isinstance(e, dict) or "error" in e)
            moves += len(map_moves)
        elapsed = seconds + (time.monotonic() - end)
        cpu = time.process_time() - cpu0
        for mid in ids:
            c.remove(mid)
    print("RESULT " + json.dumps({"index": index, "moves": moves, "errors": errors, "seconds": elapsed,
                                   "cpu_seconds": cpu}), flush=True)


def batch_service_rate(endpoint: str, service: Child, form: str, seconds: float) -> dict[str, Any]:
    start_at = time.time() + 4.0  # every worker has loaded the scene and registered its movers by then
    procs = [subprocess.Popen([sys.executable, "-m", "benchmarks.bench_batches", "batch-worker", endpoint, str(i),
                               repr(start_at), repr(seconds), form],
                              cwd=common.ROOT, env=child_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for i in range(BATCH_PROCESSES)]
    time.sleep(max(0.0, start_at - time.time()))
    cpu0 = service.cpu_seconds()
    reports = collect_reports(procs, seconds + 90.0, "batch worker")
    cpu = service.cpu_seconds() - cpu0  # includes the workers' remove requests: negligible
    moves = sum(r["moves"] for r in reports)
    wall = max(r["seconds"] for r in reports)
    row = {"form": form, "processes": BATCH_PROCESSES, "batch": 2 * (BATCH_MOVERS // BATCH_PROCESSES),
           "moves": moves, "seconds": wall, "moves_per_s": moves / wall, "errors": sum(r["errors"] for r in reports),
           "service_cpu_us_per_move": cpu / moves * 1e6 if moves else None,
           "client_cpu_us_per_move": sum(r["cpu_seconds"] for r in reports) / moves * 1e6 if moves else None}
    log(f"service (batch workload): {BATCH_PROCESSES} proc x batch {row['batch']} ({form:7s}): {row['moves_per_s']:9.0f} "
        f"moves/s, service CPU {row['service_cpu_us_per_move']:.1f} µs/move, "
        f"client CPU {row['client_cpu_us_per_move']:.1f} µs/move, {row['errors']} errors")
    return row


def _batch_engine_once(seconds: float, engine_root: Path | None) -> dict[str, Any]:
    """World.move and run_batch in a child, with the same engine the service imports (`engine_root`'s when given)."""
    p = subprocess.run([sys.executable, "-m", "benchmarks.bench_batches", "batch-engine", repr(seconds)],
                       cwd=engine_root or common.ROOT, env=child_env(engine_root), capture_output=True, text=True,
                       timeout=seconds + 120)
    lines = [ln for ln in p.stdout.splitlines() if ln.startswith("ENGINE ")]
    if p.returncode != 0 or not lines:
        raise RuntimeError(f"in-process engine run failed ({p.returncode}):\n{p.stderr[-2000:]}")
    engine: dict[str, Any] = json.loads(lines[-1][7:])
    log(f"service (batch workload): World.move in process on the same movers: {engine['moves_per_s']:9.0f} moves/s, "
        f"CPU {engine['cpu_us_per_move']:.1f} µs/move; run_batch in process: "
        f"{engine['run_batch']['moves_per_s']:9.0f} moves/s, CPU {engine['run_batch']['cpu_us_per_move']:.1f} µs/move")
    return engine


def _engine_inside(endpoint: str) -> float | None:
    """The service's own mean engine time per move over its window (Stats `engine_ms`), in µs."""
    from clients import Client

    with Client([endpoint], timeout=30.0) as c:
        (stats,) = c.stats()
    mean = (stats.get("engine_ms") or {}).get("mean")
    return None if mean is None else float(mean) * 1e3


def _median_row(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """One row of medians over the rounds' rows (numbers only; the rounds are kept beside it)."""
    out = dict(rows[0])
    for k, v in rows[0].items():
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            vals = [r[k] for r in rows if isinstance(r.get(k), (int, float))]
            out[k] = statistics.median(vals) if vals else None
    out["rounds"] = rows
    return out


# -- the raw-client column form against the bound, in windows paired half a second apart ----------------
# The rounds above measure the raw-client form and the bound in windows of seconds, minutes apart. On this
# shared machine the speed of the same code swings by a third between such windows, and their ratio with
# it (0.62 to 0.92 of the bound across one run's rounds). Here the same client processes alternate between
# the two targets on one schedule of short windows (service, bound, bound, service, ...: each pair
# adjacent, which comes first alternating) and the ratio is taken pair by pair, each pair seeing nearly the
# same machine. A worker registers its share of the movers with the service and sends its column request's
# raw bytes, as the raw-client form does; to the bare queryable it sends its share's request as the bound's
# clients do. A window's rate counts the requests started in it over the time from its first request's
# start to its last reply.
#: the target of window w: the service ("service") or the bound ("bare"), in ABBA order
SERVICE, BARE = "service", "bare"


def window_targets(windows: int) -> list[str]:
    """Service, bound, bound, service, service, bound, ...: each pair (2k, 2k+1) holds one of each,
    and which comes first alternates, so that a drift over a pair favours neither."""
    return [SERVICE if w % 4 in (0, 3) else BARE for w in range(windows)]


def pair_ratios(service_rates: list[float], bare_rates: list[float], targets: list[str]) -> list[float]:
    """The service's rate over the bound's in each adjacent pair of windows (rates in window order)."""
    rates: dict[str, list[float]] = {SERVICE: list(service_rates), BARE: list(bare_rates)}
    by_window = [rates[t].pop(0) for t in targets]
    out = []
    for k in range(0, len(targets) - 1, 2):
        a, b = by_window[k], by_window[k + 1]
        service, bare = (a, b) if targets[k] == SERVICE else (b, a)
        out.append(service / bare)
    return out


def _paired_worker(service_endpoint: str, bare_endpoint: str, index: int, start_at: float, window: float,
                   windows: int) -> dict[str, Any]:
    """This process's share, sent in every window to that window's target: per window, moves and seconds."""
    import msgpack
    import zenoh

    from clients import Client
    from engine import load_scene
    from service.bus.zconfig import make_config

    from .scenes import PLAYER

    share = BATCH_MOVERS // BATCH_PROCESSES
    spots = batch_spots(load_scene(str(demo_scene())))[index * share:(index + 1) * share]
    bare_session = zenoh.open(make_config(connect=[bare_endpoint]))
    try:
        with Client([service_endpoint], timeout=30.0) as c:
            ids = [c.register(PLAYER, pos, contact_plane=plane, contact_plane_cell=cell).id for pos, plane, cell in spots]
            items = 2 * len(ids)
            route = {SERVICE: (c.session, zenoh.KeyExpr(c.keys.move(c.landblock_of(ids[0]))), _column_request_bytes(ids)),
                     BARE: (bare_session, zenoh.KeyExpr(f"{BARE_KEY}/{index}"),
                            _column_request_bytes(list(range(index * share + 1, (index + 1) * share + 1))))}
            moves: list[int] = []
            seconds: list[float] = []
            errors = 0
            for w, target in enumerate(window_targets(windows)):
                session, key, payload = route[target]
                time.sleep(max(0.0, start_at + w * window - time.time()))
                end = start_at + (w + 1) * window
                n = 0
                t0 = time.time()
                while time.time() < end:
                    failures = items
                    for reply in session.get(key, payload=payload, timeout=30.0):
                        if reply.ok is not None:
                            body = reply.ok.payload.to_bytes()
                            if target == BARE:
                                failures = 0
                            else:
                                msg = msgpack.unpackb(body)
                                failures = len(msg.get("errors") or ()) if msg.get("n") == items else items
                    errors += failures
                    n += items
                moves.append(n)
                seconds.append(time.time() - t0)
            for mid in ids:
                c.remove(mid)
    finally:
        bare_session.close()
    return {"index": index, "moves": moves, "seconds": seconds, "errors": errors}


def paired_raw_columns(service_endpoint: str, bare_endpoint: str, window: float, windows: int) -> dict[str, Any]:
    """The raw-client column form against the bound in `windows` paired windows of `window` seconds:
    each pair's ratio, their median, and each target's median rate (moves/s, all workers together)."""
    start_at = time.time() + 5.0  # every worker has loaded the scene and registered its movers by then
    procs = [subprocess.Popen([sys.executable, "-m", "benchmarks.bench_batches", "batch-paired", service_endpoint,
                               bare_endpoint, str(i), repr(start_at), repr(window), str(windows)],
                              cwd=common.ROOT, env=child_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for i in range(BATCH_PROCESSES)]
    reports = collect_reports(procs, 5.0 + window * windows + 90.0, "paired batch worker")
    targets = window_targets(windows)
    # each window's rate: the workers' moves over the longest of their times in it
    rates = [sum(r["moves"][w] for r in reports) / max(r["seconds"][w] for r in reports) for w in range(windows)]
    service_rates = [r for r, t in zip(rates, targets) if t == SERVICE]
    bare_rates = [r for r, t in zip(rates, targets) if t == BARE]
    ratios = pair_ratios(service_rates, bare_rates, targets)
    out = {"window_s": window, "windows": windows, "pair_ratios": ratios, "ratio": statistics.median(ratios),
           "service_moves_per_s": statistics.median(service_rates), "bare_moves_per_s": statistics.median(bare_rates),
           "errors": sum(r["errors"] for r in reports)}
    quartiles = statistics.quantiles(ratios, n=4) if len(ratios) >= 2 else [ratios[0]] * 3
    log(f"service (batch workload): columns, raw clients / the bound, {len(ratios)} pairs of {window:.1f} s windows: "
        f"median {out['ratio']:.3f} (quartiles {quartiles[0]:.3f}-{quartiles[2]:.3f}); "
        f"{out['service_moves_per_s']:.0f} vs {out['bare_moves_per_s']:.0f} moves/s, {out['errors']} errors")
    return out



def batch_workload(quick: bool, engine_root: Path | None = None) -> dict[str, Any]:
    """The batch workload through the map and the column form, and World.move in process, in one run:
    in rounds (engine, then each form), so that each ratio compares minutes of the same machine state on
    this shared machine; the figures are the medians over the rounds, each round's ratio its own."""
    seconds, rounds = (2.0, 1) if quick else (5.0, 3)
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    service = Child([sys.executable, "-m", "service", "--scene", str(demo_scene()), "--listen", endpoint,
                     "--log-level", "WARNING", "--queue", "4096"], "acphys service ready", engine_root)
    bare_endpoint = f"tcp/127.0.0.1:{free_port()}"
    bare = Child([sys.executable, "-m", "benchmarks.bench_batches", "batch-bare", bare_endpoint], "bare queryable ready",
                 engine_root)
    engines: list[dict[str, Any]] = []
    per_form: dict[str, list[dict[str, Any]]] = {form: [] for form in BATCH_FORMS}
    bounds: list[dict[str, Any]] = []
    try:
        for _ in range(rounds):
            engine = _batch_engine_once(seconds, engine_root)
            engines.append(engine)
            for form in BATCH_FORMS:
                row = batch_service_rate(endpoint, service, form, seconds)
                row["ratio_to_engine"] = row["moves_per_s"] / engine["moves_per_s"]
                # CPU per move, less sensitive to other processes on a shared machine than the rates
                row["cpu_ratio_to_engine"] = engine["cpu_us_per_move"] / row["service_cpu_us_per_move"]
                inside = _engine_inside(endpoint)
                row["engine_in_service_us"] = inside
                row["service_beyond_engine_us"] = None if inside is None else row["service_cpu_us_per_move"] - inside
                log(f"service (batch workload): {form} / engine in process = {row['ratio_to_engine']:.2f} in moves/s, "
                    f"{row['cpu_ratio_to_engine']:.2f} in CPU per move (target >= 0.8); the engine inside the service "
                    f"{inside or float('nan'):.1f} µs/move")
                per_form[form].append(row)
            row = batch_service_rate(bare_endpoint, bare, BARE_FORM, seconds)
            row["ratio_to_engine"] = row["moves_per_s"] / engine["moves_per_s"]
            row["cpu_ratio_to_engine"] = engine["cpu_us_per_move"] / row["service_cpu_us_per_move"]
            log(f"service (batch workload): {BARE_FORM} / engine in process = {row['ratio_to_engine']:.2f} in moves/s")
            bounds.append(row)
        # the target's figure: the raw-client form and the bound alternating in half-second windows
        paired = paired_raw_columns(endpoint, bare_endpoint, PAIRED_WINDOW_S, 16 if quick else PAIRED_WINDOWS)
    finally:
        service.stop()
        bare.stop()
    engine_row = _median_row([{k: v for k, v in e.items() if k != "run_batch"} for e in engines])
    engine_row["run_batch"] = _median_row([e["run_batch"] for e in engines])
    return {"engine": engine_row, "service": [_median_row(rows) for rows in per_form.values()],
            "bare": _median_row(bounds), "paired": paired,
            "movers": BATCH_MOVERS, "spacing_m": BATCH_SPACING, "step_m": BATCH_STEP, "forms": BATCH_FORMS,
            "rounds": rounds, "seconds_each": seconds}


if __name__ == "__main__":
    if sys.argv[1] == "batch-worker":
        batch_worker_main(sys.argv[2], int(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5]), sys.argv[6])
    elif sys.argv[1] == "batch-paired":
        print("RESULT " + json.dumps(_paired_worker(sys.argv[2], sys.argv[3], int(sys.argv[4]), float(sys.argv[5]),
                                                    float(sys.argv[6]), int(sys.argv[7]))), flush=True)
    elif sys.argv[1] == "batch-bare":
        batch_bare_main(sys.argv[2])
    elif sys.argv[1] == "batch-engine":
        print("ENGINE " + json.dumps(batch_engine_rate(float(sys.argv[2]))), flush=True)
    elif sys.argv[1] == "batch":
        print(json.dumps(batch_workload(quick=True)))
    else:
        raise SystemExit(f"unknown role {sys.argv[1]!r}")
