"""What `--state` with its log costs and what it keeps: `python3 -m benchmarks --only durability`.

- Throughput and one move's round trip under each `--state-sync` policy against an instance without
  `--state`, in the same run: four instances of the demo world (none, every-second, always, never), each
  with 1000 movers, measured in turn, round after round (so drift of the machine falls on all alike):
  column batches of 100 offset moves, map batches of 100 (`Client.move_many`), and one offset move at a
  time (`Client.move`), each for a fixed time, one client in this process.
- Log growth: the bytes the log gains per million moves, read from an instance's log after a known
  number of column moves and of single moves.
- Restart time with a log of 1 M and 10 M moves (written by the log's own writer, in records of 100 moves
  of 1000 movers, as column batches leave them, and in records of one move, as single moves leave them):
  the log's framing and checksums alone and the whole replay (service.persistence.state_replay.load_saved),
  in this process, and an `acphys serve` start until it answers (replay, restore, compaction, Python and
  Zenoh start), against a start without state.
- Kills: benchmarks/durability_kills.py's random SIGKILLs under each policy, with its checks.
"""

from __future__ import annotations

import shutil
import struct
import tempfile
import time
from pathlib import Path
from typing import Any

import msgpack
import numpy as np

from . import common
from .common import log
from .durability_kills import DEMO_SCENE, Service, run_kills

__all__ = ["run", "section", "make_log"]

POLICIES = ("every-second", "always", "never")
CONFIGS = ("none", *POLICIES)
MOVERS = 1000
BATCH = 100


def _register_movers(c: Any, n: int) -> list[int]:
    from clients.demo.world import global_to_cell
    from engine.geometry import Position, Vec3

    from .durability_kills import player_spec

    world = _world()
    ids = []
    for k in range(n):
        gx, gy = 6.0 + (k % 30) * 6.0, 6.0 + (k // 30) * 5.5
        cell, x, y = global_to_cell(gx, gy)
        pos = Position.at(cell, Vec3(x, y, world.terrain_height(cell, x, y) + 0.5))
        ids.append(c.register(player_spec(), pos).id)
    return ids


_WORLD: Any = None


def _world() -> Any:
    global _WORLD
    if _WORLD is None:
        from engine import load_scene

        _WORLD = load_scene(str(DEMO_SCENE))
    return _WORLD


def _columns(c: Any, ids: list[int], seconds: float) -> tuple[int, float]:
    arr = np.array(ids, dtype=np.uint64)
    moves, k = 0, 0
    began = time.perf_counter()
    while time.perf_counter() - began < seconds:
        chunk = arr[(k * BATCH) % len(arr):(k * BATCH) % len(arr) + BATCH]
        sign = 1.0 if k % 2 == 0 else -1.0
        c.move_batch(chunk, offsets=np.tile([0.01 * sign, 0.0, 0.0], (len(chunk), 1)))
        moves += len(chunk)
        k += 1
    return moves, time.perf_counter() - began


def _maps(c: Any, ids: list[int], seconds: float) -> tuple[int, float]:
    from clients import Move

    moves, k = 0, 0
    began = time.perf_counter()
    while time.perf_counter() - began < seconds:
        start = (k * BATCH) % len(ids)
        sign = 1.0 if k % 2 == 0 else -1.0
        c.move_many([Move(i, offset=(0.01 * sign, 0.0, 0.0)) for i in ids[start:start + BATCH]])
        moves += BATCH
        k += 1
    return moves, time.perf_counter() - began


def _singles(c: Any, ids: list[int], seconds: float) -> list[float]:
    samples = []
    k = 0
    began = time.perf_counter()
    while time.perf_counter() - began < seconds:
        sign = 1.0 if k % 2 == 0 else -1.0
        t0 = time.perf_counter()
        c.move(ids[k % len(ids)], offset=(0.01 * sign, 0.0, 0.0))
        samples.append(time.perf_counter() - t0)
        k += 1
    return samples


def _log_bytes(state: Path) -> int:
    return sum(p.stat().st_size for p in state.parent.glob(state.name + ".journal-*"))


def measure_costs(rounds: int, seconds: float, engine_root: Path | None) -> dict[str, Any]:
    """Throughput and round trip per configuration, interleaved round by round; log growth per move."""
    from clients import Client

    tmp = Path(tempfile.mkdtemp(prefix="acphys-durability-"))
    services: dict[str, Service] = {}
    clients: dict[str, Any] = {}
    ids: dict[str, list[int]] = {}
    out: dict[str, Any] = {cfg: {"columns": [], "maps": [], "single_us": [], "columns_cpu_us": [], "maps_cpu_us": [],
                                 "single_cpu_us": []} for cfg in CONFIGS}
    growth: dict[str, Any] = {}
    load_start = _loadavg()
    try:
        for cfg in CONFIGS:
            state = None if cfg == "none" else tmp / cfg / "movers.state"
            if state is not None:
                state.parent.mkdir()
            services[cfg] = Service(state, cfg, engine_root, interval=10.0)
            services[cfg].start()
            clients[cfg] = Client([services[cfg].endpoint], timeout=30.0)
            clients[cfg].wait_ready()
            ids[cfg] = _register_movers(clients[cfg], MOVERS)
        for r in range(rounds):
            for cfg in CONFIGS:
                c = clients[cfg]
                cpu = services[cfg].cpu_seconds()
                n, t = _columns(c, ids[cfg], seconds)
                out[cfg]["columns"].append(n / t)
                out[cfg]["columns_cpu_us"].append((services[cfg].cpu_seconds() - cpu) / n * 1e6)
                cpu = services[cfg].cpu_seconds()
                n, t = _maps(c, ids[cfg], seconds)
                out[cfg]["maps"].append(n / t)
                out[cfg]["maps_cpu_us"].append((services[cfg].cpu_seconds() - cpu) / n * 1e6)
                cpu = services[cfg].cpu_seconds()
                samples = _singles(c, ids[cfg], seconds)
                out[cfg]["single_cpu_us"].append((services[cfg].cpu_seconds() - cpu) / len(samples) * 1e6)
                out[cfg]["single_us"].extend(s * 1e6 for s in samples)
            log(f"  round {r + 1}/{rounds}: " + ", ".join(
                f"{cfg} {out[cfg]['columns'][-1]:.0f}/{out[cfg]['maps'][-1]:.0f} moves/s" for cfg in CONFIGS))
        # log growth: an instance of its own, no state file written meanwhile (interval 3600 s)
        state = tmp / "growth" / "movers.state"
        state.parent.mkdir()
        svc = Service(state, "every-second", engine_root, interval=3600.0)
        svc.start()
        try:
            with Client([svc.endpoint], timeout=30.0) as c:
                c.wait_ready()
                movers = _register_movers(c, MOVERS)
                time.sleep(1.5)
                before = _log_bytes(state)
                n, _t = _columns(c, movers, seconds)
                time.sleep(1.5)
                after = _log_bytes(state)
                growth["columns_bytes_per_move"] = (after - before) / n
                before = after
                samples = _singles(c, movers, seconds)
                time.sleep(1.5)
                growth["single_bytes_per_move"] = (_log_bytes(state) - before) / len(samples)
        finally:
            svc.stop()
    finally:
        for c in clients.values():
            c.close()
        for s in services.values():
            s.stop()
        shutil.rmtree(tmp, ignore_errors=True)
    result: dict[str, Any] = {"rounds": rounds, "seconds": seconds, "movers": MOVERS, "batch": BATCH,
                              "growth": growth, "loadavg_start": load_start, "loadavg_end": _loadavg()}
    for cfg in CONFIGS:
        single = sorted(out[cfg]["single_us"])
        # each round's figure over the no-state instance's in the same round (measured next to it in time):
        # the median of these is what the machine's drift from round to round blurs least
        ratios = {w: [x / y for x, y in zip(out[cfg][w], out["none"][w])] for w in ("columns", "maps")}
        result[cfg] = {
            "columns_share": float(np.median(ratios["columns"])), "maps_share": float(np.median(ratios["maps"])),
            "columns_share_rounds": ratios["columns"], "maps_share_rounds": ratios["maps"],
            "columns_moves_s": float(np.median(out[cfg]["columns"])), "columns_rounds": out[cfg]["columns"],
            "maps_moves_s": float(np.median(out[cfg]["maps"])), "maps_rounds": out[cfg]["maps"],
            "single_p50_us": common.pct(single, 50), "single_p90_us": common.pct(single, 90),
            "single_count": len(single),
            # the service process's CPU time per move (user + system, all its threads): what the log costs it,
            # less blurred than throughput by whatever else the machine runs
            "columns_cpu_us": float(np.median(out[cfg]["columns_cpu_us"])),
            "maps_cpu_us": float(np.median(out[cfg]["maps_cpu_us"])),
            "single_cpu_us": float(np.median(out[cfg]["single_cpu_us"])),
        }
    return result


def _loadavg() -> list[float]:
    """The machine's load averages (1, 5, 15 minutes): others' work on the same cores blurs throughput."""
    try:
        return [float(x) for x in Path("/proc/loadavg").read_text().split()[:3]]
    except (OSError, ValueError):
        return []


def count_instructions(engine_root: Path | None) -> dict[str, Any]:
    """benchmarks/instructions_durability.py's callgrind counts with the engine measured here (the compiled
    copy, or the working tree's when it is compiled); why not, when they cannot be made."""
    import sys

    from .instructions_durability import count_policies, unavailable

    paths = [engine_root, common.ROOT] if engine_root is not None else [common.ROOT]
    why = unavailable(sys.executable, paths)
    if why is not None:
        return {"unavailable": why}
    return count_policies(sys.executable, paths)


def measure_inprocess(engine_root: Path | None, requests: int = 3000, policy: str = "every-second") -> dict[str, Any]:
    """The log's own cost on the column path, measured inside one process (a child, with the engine copy):
    a core with 1000 movers runs `requests` column batches of 100 offset moves with the log attached; the
    time spent in the log's code on the engine thread (building the record, committing) and the CPU time
    of the log's thread (framing, checksums, writes, syncs), against the whole time per move."""
    import json
    import subprocess
    import sys

    env = dict(__import__("os").environ)
    first = [str(engine_root)] if engine_root is not None else []
    env["PYTHONPATH"] = __import__("os").pathsep.join([*first, str(common.ROOT)])
    proc = subprocess.run([sys.executable, "-m", "benchmarks.bench_durability", "inprocess", policy, str(requests)],
                          cwd=engine_root or common.ROOT, env=env, capture_output=True, text=True, timeout=900,
                          check=False)
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("INPROCESS ")]
    if proc.returncode != 0 or not lines:
        raise RuntimeError(f"in-process measurement failed: {proc.stderr[-2000:]}")
    return dict(json.loads(lines[-1][len("INPROCESS "):]))


def _inprocess(policy: str, requests: int) -> dict[str, Any]:
    import tempfile as tf

    import engine
    import service.column_moves as cm
    import service.persistence.journal as jm
    from service.protocol.column_request import parse_column_request
    from service.persistence.journal_records import MoverLog

    from .durability_kills import Mirror

    mirror = Mirror()
    core = mirror.core
    from clients.demo.world import global_to_cell
    from engine.geometry import Position, Vec3

    for k in range(MOVERS):
        gx, gy = 6.0 + (k % 30) * 6.0, 6.0 + (k // 30) * 5.5
        cell, x, y = global_to_cell(gx, gy)
        mirror.register(k + 1, Position.at(cell, Vec3(x, y, core.world.terrain_height(cell, x, y) + 0.5)))
    reqs = []
    for k in range(20):
        chunk = [(k * BATCH) % MOVERS + i + 1 for i in range(BATCH)]
        sign = 1.0 if k % 2 == 0 else -1.0
        reqs.append(parse_column_request({"v": 1, "kind": "offset", "columns": {
            "id": struct.pack(f"<{BATCH}Q", *chunk), "offset": struct.pack(f"<{3 * BATCH}d", *([0.01 * sign, 0.0, 0.0] * BATCH))}}))
    spent = {"record": 0.0, "commit": 0.0, "log_thread_cpu": 0.0}
    journal_fn, commit_fn, write_fn = cm._journal, core.commit, jm.Journal._write

    def timed_journal(*a: Any) -> None:
        t = time.perf_counter()
        journal_fn(*a)
        spent["record"] += time.perf_counter() - t

    def timed_commit() -> None:
        t = time.perf_counter()
        commit_fn()
        spent["commit"] += time.perf_counter() - t

    def timed_write(self: Any, sync: bool) -> None:
        t = time.thread_time()
        write_fn(self, sync)
        spent["log_thread_cpu"] += time.thread_time() - t

    for k in range(200):  # warm
        cm.run_columns(core, reqs[k % 20], 0.0)
    cm._journal = timed_journal  # type: ignore[assignment]
    core.commit = timed_commit  # type: ignore[method-assign]
    jm.Journal._write = timed_write  # type: ignore[method-assign]
    with tf.TemporaryDirectory() as tmp:
        journal = jm.Journal(Path(tmp) / "s.state", 0, policy)
        core.attach_log(MoverLog(journal))
        began = time.perf_counter()
        for k in range(requests):
            cm.run_columns(core, reqs[k % 20], 0.0)
        total = time.perf_counter() - began
        journal.close()
    moves = requests * BATCH
    return {"policy": policy, "moves": moves, "engine_file": engine.__file__,
            "total_us_per_move": total / moves * 1e6, "record_us_per_move": spent["record"] / moves * 1e6,
            "commit_us_per_move": spent["commit"] / moves * 1e6,
            "log_thread_cpu_us_per_move": spent["log_thread_cpu"] / moves * 1e6}


def make_log(state: Path, moves: int, per_record: int, movers: int = MOVERS) -> int:
    """A log of `movers` registers then `moves` moves in records of `per_record`, written by the log's own
    writer (policy never: written, not synced); its size in bytes."""
    from clients.demo.world import global_to_cell
    from service.protocol.codec import encode_mover_spec
    from service.persistence.journal import Journal
    from service.persistence.journal_records import MOVES, RECORD_HEAD, REGISTER, mover_state_bytes

    from .durability_kills import player_spec

    world = _world()
    cell, x, y = global_to_cell(40.0, 40.0)
    from engine.geometry import Position, Vec3

    engine_id = world.add_mover(player_spec(), Position.at(cell, Vec3(x, y, world.terrain_height(cell, x, y) + 0.5)))
    template = bytearray(mover_state_bytes(world.movers[engine_id]))
    world.remove_mover(engine_id)
    states = []
    for k in range(movers):  # each its own place on A9B4's ground (origin x, y at bytes 32..47)
        b = bytearray(template)
        gx, gy = 6.0 + (k % 30) * 6.0, 6.0 + (k // 30) * 5.5
        struct.pack_into("<3d", b, 32, gx, gy, world.terrain_height(cell, gx, gy) + 0.5)
        states.append(bytes(b))
    spec = msgpack.packb([encode_mover_spec(player_spec())], use_bin_type=True)
    j = Journal(state, 0, "never")
    for k in range(movers):
        j.append(RECORD_HEAD.pack(REGISTER, 1) + struct.pack("<QQ", k + 1, 0) + states[k] + spec)
    # the movers take turns: row g of the log (from 0) moves mover g % movers to its seq g // movers + 1 (a mover
    # named twice in one record has its seq after the second in both rows). The records' bytes are made with
    # numpy, a block of them at a time (10 M single moves in seconds, not minutes)
    table = np.frombuffer(b"".join(states), np.uint8).reshape(movers, -1)
    head = np.frombuffer(RECORD_HEAD.pack(MOVES, per_record), np.uint8)
    done = 0
    while done < moves:
        n = min(per_record, moves - done)
        count = max(1, min(100_000 // n, (moves - done) // n))  # records of n rows in this block
        g = done + np.arange(count * n, dtype=np.uint64).reshape(count, n)
        who = (g % np.uint64(movers)).astype(np.intp)
        rows = np.empty((count, RECORD_HEAD.size + n * (16 + table.shape[1])), np.uint8)
        rows[:, :RECORD_HEAD.size] = head if n == per_record else np.frombuffer(RECORD_HEAD.pack(MOVES, n), np.uint8)
        at = RECORD_HEAD.size
        rows[:, at:at + 8 * n] = (who + 1).astype("<u8").view(np.uint8).reshape(count, 8 * n)
        m = np.uint64(movers)
        last = g + m * ((g[:, -1:] - g) // m)  # a mover's rows in one record all carry its seq after the last
        rows[:, at + 8 * n:at + 16 * n] = (last // m + np.uint64(1)).astype("<u8").view(np.uint8).reshape(count, 8 * n)
        rows[:, at + 16 * n:] = table[who].reshape(count, -1)
        for r in range(count):
            j.append(rows[r].tobytes(), moves=n)
            j.commit()
        done += count * n
    j.close()
    return _log_bytes(state)


def measure_restarts(sizes: list[tuple[int, int]], engine_root: Path | None) -> list[dict[str, Any]]:
    """Per (moves, moves per record): the log's size; in this process the log's framing and checksums alone
    (JournalScan, as the start reads it) and the whole replay (load_saved: that, the records applied and the
    movers made); and a service start until it answers (with the world's load, the restore, the compaction
    and Python's and Zenoh's start), against a start without state. The machine's load with each."""
    from service.persistence.frame_runs import check_run
    from service.persistence.journal import JournalScan, journal_files
    from service.persistence.state_replay import load_saved

    rows = []
    base = _start_seconds(None, engine_root)
    for moves, per in sizes:
        tmp = Path(tempfile.mkdtemp(prefix="acphys-restart-"))
        try:
            state = tmp / "movers.state"
            t0 = time.perf_counter()
            size = make_log(state, moves, per)
            made = time.perf_counter() - t0
            t0 = time.perf_counter()
            for p in journal_files(state).values():
                for _item in JournalScan(p, check_run).items():
                    pass
            scan = time.perf_counter() - t0
            t0 = time.perf_counter()
            loaded = load_saved(state)
            replay = time.perf_counter() - t0
            assert loaded.movers is not None and len(loaded.movers) == MOVERS
            load = _loadavg()
            start = _start_seconds(state, engine_root)
            rows.append({"moves": moves, "per_record": per, "log_bytes": size, "write_s": made, "scan_s": scan,
                         "replay_s": replay, "start_s": start, "start_without_state_s": base, "loadavg": load})
            log(f"  {moves:,} moves ({per}/record): log {size / 1e6:.0f} MB, framing and checksums {scan:.2f} s, "
                f"replay {replay:.2f} s, start {start:.2f} s (without state {base:.2f} s; load {load[:1]})")
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
    return rows


def _start_seconds(state: Path | None, engine_root: Path | None) -> float:
    svc = Service(state, "every-second", engine_root)
    t0 = time.perf_counter()
    svc.start()
    took = time.perf_counter() - t0
    svc.stop()
    return took


def run(quick: bool, engine_root: Path | None = None) -> dict[str, Any]:
    out: dict[str, Any] = {"engine": "compiled copy (benchmarks/out/compiled)" if engine_root else
                           ("compiled" if common.compiled_modules() else "interpreted")}
    log("durability: throughput and round trip per policy")
    out["costs"] = measure_costs(2 if quick else 5, 1.5 if quick else 3.0, engine_root)
    log("durability: the log's own cost on the column path, in process")
    try:
        out["inprocess"] = measure_inprocess(engine_root, 1000 if quick else 4000)
        ip = out["inprocess"]
        log(f"  engine thread {ip['record_us_per_move'] + ip['commit_us_per_move']:.3f} µs/move in the log's code, "
            f"log thread {ip['log_thread_cpu_us_per_move']:.3f} µs/move, of {ip['total_us_per_move']:.2f} µs/move")
    except Exception as e:  # noqa: BLE001 - the doc says why instead
        out["inprocess"] = {"failed": f"{type(e).__name__}: {e}"}
    log("durability: instructions per move of the column path under each policy (callgrind)")
    try:
        out["instructions"] = count_instructions(engine_root)
        for cfg, row in out["instructions"].get("rows", {}).items():
            log(f"  {cfg}: {row['engine_thread']:,.0f} on the engine thread, {row['other_threads']:,.0f} on the log's")
    except Exception as e:  # noqa: BLE001 - the doc says why instead
        out["instructions"] = {"unavailable": f"the count failed: {type(e).__name__}: {e}"}
    log("durability: restart with a log")
    sizes = ([(100_000, 100), (100_000, 1)] if quick else
             [(1_000_000, 100), (1_000_000, 1), (10_000_000, 100), (10_000_000, 1)])
    out["restarts"] = measure_restarts(sizes, engine_root)
    log("durability: kills")
    kills = []
    for policy in POLICIES:
        n = 3 if quick else 12
        began = time.perf_counter()
        k = run_kills(policy, n, seed=100 + POLICIES.index(policy), engine_root=engine_root)
        kills.append({"policy": policy, "kills": k.kills, "requests": k.requests, "moves": k.moves_answered,
                      "violations": k.violations, "lost_moves_max": max(k.lost_moves, default=0),
                      "lost_moves_total": sum(k.lost_moves), "lost_age_max_s": max(k.lost_age_s, default=0.0),
                      "restart_p50_s": common.pct(k.restart_s, 50) if k.restart_s else None,
                      "seconds": time.perf_counter() - began})
        log(f"  {policy}: {k.kills} kills, {len(k.violations)} violation(s), lost at most {max(k.lost_moves, default=0)} "
            f"move(s) per kill, the oldest {max(k.lost_age_s, default=0.0):.2f} s before its kill")
    out["kills"] = kills
    return out


def _share(row: dict[str, Any], workload: str, none: dict[str, Any]) -> str:
    """The median over rounds of the row's throughput over no --state's in the same round."""
    paired = row.get(f"{workload}_share")
    if paired is None:
        base = none.get(f"{workload}_moves_s", 0)
        paired = row[f"{workload}_moves_s"] / base if base else float("nan")
    return f"{100.0 * paired:.0f} %"


def _targets(data: dict[str, Any]) -> list[str]:
    """The durability targets against this run's figures."""
    costs, ip = data.get("costs", {}), data.get("inprocess", {})
    es = costs.get("every-second", {})
    out = ["Durability targets:", ""]
    if es:
        from .instructions_durability import target_words

        rounds = es.get("columns_share_rounds", [])
        spread = (f", {100 * min(rounds):.0f} to {100 * max(rounds):.0f} % over the {len(rounds)} rounds"
                  if rounds else "")
        out.append(f"- `every-second` costs at most 5 % of throughput: end to end, column batches ran at "
                   f"{100 * es.get('columns_share', float('nan')):.0f} %{spread} and map batches at "
                   f"{100 * es.get('maps_share', float('nan')):.0f} % of the instance without `--state` (medians of "
                   "per-round ratios; the machine's load below): "
                   + ("met by the median" if es.get("columns_share", 0) >= 0.95 else "not met by the median")
                   + (", but rounds that far apart cannot tell 5 % from noise. " if rounds and
                      max(rounds) - min(rounds) > 0.10 else ". ")
                   + target_words(data.get("instructions", {}), ip))
    al = costs.get("always", {})
    if al and costs.get("none"):
        out.append(f"- `always` costs what the disk costs: here one fdatasync per request; column batches at "
                   f"{100 * al.get('columns_share', float('nan')):.0f} %, one move's round trip "
                   f"{al['single_p50_us']:.0f} µs against {costs['none']['single_p50_us']:.0f} µs (p50).")
    rs = data.get("restarts", [])
    big = [r for r in rs if r["moves"] >= 10_000_000 and r["per_record"] > 1]
    one = [r for r in rs if r["per_record"] == 1]
    big_one = [r for r in one if r["moves"] >= 10_000_000]
    if big:
        r = big[0]
        line = (f"- A restart with a 10 M-move log takes at most 10 s: {r['start_s']:.1f} s until the restarted "
                f"instance answers ({r['replay_s']:.1f} s of it the replay, {r.get('scan_s', float('nan')):.1f} s "
                f"of that the log's framing and checksums) for 10 M moves logged in records of {r['per_record']} "
                "(column batches). "
                + ("Met for such a log." if r["start_s"] <= 10.0 else
                   f"Not met in this run (without state the start took {r['start_without_state_s']:.1f} s: the "
                   "machine's load weighs on both)."))
        if big_one:
            o = big_one[0]
            line += (f" Single moves make one record each: with 10 M of them the start took {o['start_s']:.1f} s "
                     f"({o['replay_s']:.1f} s the replay): " + ("met." if o["start_s"] <= 10.0 else "not met."))
        elif one:
            o = one[0]
            line += (f" Single moves make one record each: {o['moves'] / 1e6:.0f} M of them replayed in "
                     f"{o['replay_s']:.1f} s, so 10 M would take about {10_000_000 / o['moves'] * o['replay_s']:.0f} s "
                     "to replay (a log that long builds up only with `--state-interval 0`: with the default the "
                     "log starts again every 10 s).")
        out.append(line)
    return [*out, ""]


def _range(values: list[float]) -> str:
    return f"{min(values):,.0f} to {max(values):,.0f}" if values else "?"


def _spread(row: dict[str, Any], workload: str) -> str:
    """The lowest and highest per-round share of a workload, e.g. "88-97"."""
    rounds = row.get(f"{workload}_share_rounds")
    return f"{100 * min(rounds):.0f}-{100 * max(rounds):.0f} %" if rounds else "?"


def _load_words(costs: dict[str, Any]) -> str:
    start, end = costs.get("loadavg_start"), costs.get("loadavg_end")
    if not start or not end:
        return ""
    return (f" The machine's load average (1 min) was {start[0]:.1f} when these rounds began and {end[0]:.1f} "
            f"when they ended (2 cores; other engineers' tests share them).")


def section(data: dict[str, Any], meta: str) -> list[str]:
    """docs/performance.md's section."""
    lines = ["## 8. Durability: `--state` and its log", "", meta, ""]
    if "failed" in data:
        return [*lines, f"The run failed: {data['failed']}", ""]
    costs = data.get("costs", {})
    none = costs.get("none", {})
    lines += _targets(data)
    lines += [f"Engine: {data.get('engine', '?')}. Four instances of the demo world, {costs.get('movers')} movers "
              f"each, one client in the benchmark's process; {costs.get('rounds')} rounds of "
              f"{costs.get('seconds')} s per workload and instance, interleaved; medians of the rounds. The state "
              "file is written every 10 s (the default) in these runs.", "",
              "| `--state-sync` | column batches: moves/s (share of none) | rounds' shares | service CPU µs/move "
              "| map batches: moves/s (share) | rounds' shares | service CPU µs/move | one move: round trip p50 / p90 "
              "µs | service CPU µs |",
              "|---|---|---|---|---|---|---|---|---|"]
    for cfg in CONFIGS:
        row = costs.get(cfg)
        if not row:
            continue
        name = "no `--state`" if cfg == "none" else f"`{cfg}`"
        lines.append(f"| {name} | {row['columns_moves_s']:,.0f} ({_share(row, 'columns', none)}) "
                     f"| {_spread(row, 'columns')} | {row.get('columns_cpu_us', float('nan')):.2f} "
                     f"| {row['maps_moves_s']:,.0f} ({_share(row, 'maps', none)}) "
                     f"| {_spread(row, 'maps')} | {row.get('maps_cpu_us', float('nan')):.2f} "
                     f"| {row['single_p50_us']:.0f} / {row['single_p90_us']:.0f} | {row.get('single_cpu_us', float('nan')):.0f} |")
    lines += ["", "The share is the median over the rounds of each round's throughput over that of the instance "
              "without `--state` in the same round. The machine is shared: the instance without `--state` alone "
              f"ranged {_range(none.get('columns_rounds', []))} moves/s in column batches from round to round, so "
              "these shares carry several per cent of noise; the instruction counts and the in-process measurement "
              "below do not." + _load_words(costs)]
    from .instructions_durability import section_lines

    lines += section_lines(data.get("instructions", {}))
    ip = data.get("inprocess", {})
    if "failed" in ip:
        lines += ["", f"In-process measurement failed: {ip['failed']}"]
    elif ip:
        engine_thread = ip["record_us_per_move"] + ip["commit_us_per_move"]
        lines += ["", f"The log's own cost on the column path, in one process ({ip['moves']:,} offset moves in batches "
                  f"of {costs.get('batch', BATCH)} over 1000 movers, `{ip['policy']}`, engine: {data.get('engine', '?')}): "
                  f"{engine_thread:.3f} µs per move on the engine thread in the log's code (building the record from "
                  f"the engine's rows and queuing it: {100.0 * engine_thread / ip['total_us_per_move']:.1f} % of the "
                  f"{ip['total_us_per_move']:.2f} µs a move takes there, plus the engine writing each mover's state "
                  f"beside its row inside run_batch, not separable here), and {ip['log_thread_cpu_us_per_move']:.3f} "
                  "µs per move of CPU on the log's own thread (framing, crc32, writes and the second's fdatasync; "
                  "crc32 and the writes release the GIL, so on a machine with a core to spare it runs beside the "
                  "engine)."]
    g = costs.get("growth", {})
    if g:
        # bytes per move = MB per million moves
        lines += ["", f"Log growth: {g['columns_bytes_per_move']:,.0f} MB per million moves sent as "
                  f"column batches of {costs.get('batch')}, {g['single_bytes_per_move']:,.0f} MB per "
                  "million single moves (each move's whole engine state, 224 bytes, with its id and seq; a record "
                  "per request). The log starts again at every state-file write (`--state-interval`, 10 s by "
                  "default), so it holds at most that long's moves unless the interval is 0."]
    rs = data.get("restarts", [])
    if rs:
        rm = data.get("restarts_meta")
        if rm:  # measured again on their own, after the rest of this section
            lines += ["", f"The restarts below were measured on their own by `{rm['command']}` at {rm['started']} on "
                      f"commit {rm['commit']} ({rm['engine']}; load average at start {rm['loadavg_at_start'][0]:.2f}); "
                      f"took {rm['seconds']:.0f} s."]
        lines += ["", "| log | size | framing and checksums (s) | replay alone (s) | `acphys serve` start until it "
                  "answers (s) | start without state (s) | load average |", "|---|---|---|---|---|---|---|"]
        for r in rs:
            lines.append(f"| {r['moves']:,} moves, {r['per_record']} per record | {r['log_bytes'] / 1e6:,.0f} MB | "
                         f"{r.get('scan_s', float('nan')):.2f} | {r['replay_s']:.2f} | {r['start_s']:.2f} | "
                         f"{r['start_without_state_s']:.2f} | {(r.get('loadavg') or [float('nan')])[0]:.2f} |")
    ks = data.get("kills", [])
    if ks:
        lines += ["", "Random SIGKILLs under load (benchmarks/durability_kills.py; its checks in its docstring):", "",
                  "| policy | kills | requests answered | violations | most moves lost at one kill | oldest lost "
                  "answer before its kill (s) | restart p50 (s) |", "|---|---|---|---|---|---|---|"]
        for k in ks:
            lines.append(f"| `{k['policy']}` | {k['kills']} | {k['requests']:,} | {len(k['violations'])} | "
                         f"{k['lost_moves_max']} | {k['lost_age_max_s']:.2f} | "
                         f"{k['restart_p50_s'] if k['restart_p50_s'] is None else round(k['restart_p50_s'], 2)} |")
    lines.append("")
    return lines


if __name__ == "__main__":
    import json
    import sys

    if len(sys.argv) == 4 and sys.argv[1] == "inprocess":
        print("INPROCESS " + json.dumps(_inprocess(sys.argv[2], int(sys.argv[3]))), flush=True)
    else:
        raise SystemExit("python3 -m benchmarks.bench_durability inprocess POLICY REQUESTS")
