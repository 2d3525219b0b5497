"""docs/performance.md's service sections (service over loopback, the service's targets, memory)."""

from __future__ import annotations

import math
import statistics
from typing import Any

from .report_format import as_float, meta_line, num, pyplot, save_plot
from .report_launches import launches_measured, launches_note

#: the batch workload's column form sent by raw Zenoh gets (benchmarks/bench_batches.py; not imported from there, which
#: would load the client library and numpy to write a report)
RAW_COLUMNS_FORM = "columns, raw clients"

__all__ = ["plot_service", "service_targets", "service_limits", "service_section", "memory_section", "client_label",
           "workers_table", "WORKERS_TEXT", "spanning_text"]

def plot_service(svc: dict[str, Any]) -> str | None:
    plt = pyplot()
    if plt is None or "latency" not in svc:
        return None
    lat = svc["latency"]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.5))
    keys = ["echo", "move", "batch10", "batch100"]
    labels = ["bare zenoh echo", "1 move", "batch of 10", "batch of 100"]
    xs = range(len(keys))
    a1.bar([x - 0.2 for x in xs], [lat[k]["median"] for k in keys], 0.4, label="median")
    a1.bar([x + 0.2 for x in xs], [lat[k]["p99"] for k in keys], 0.4, label="p99", alpha=0.6)
    a1.set_yscale("log")
    a1.set_xticks(list(xs), labels)
    a1.set_ylabel("round trip, µs")
    a1.set_title("round trip over loopback")
    a1.legend()
    thr = [r for r in svc["throughput"] if not r.get("watched")]
    groups = [(1, "objects", "1 move per request"), (100, "objects", "batches of 100, replies decoded to objects"),
              (100, "maps", "batches of 100, replies read as maps")]
    for k, (batch, mode, label) in enumerate(groups):
        rs = [r for r in thr if r["batch"] == batch and r.get("client", "objects") == mode]
        a2.bar([i + (k - 1) * 0.27 for i in range(len(rs))], [r["moves_per_s"] for r in rs], 0.27, label=label)
    procs = [r["processes"] for r in thr if r["batch"] == 1]
    a2.set_xticks(list(range(len(procs))), [f"{p} client process(es)" for p in procs])
    a2.axhline(50000, color="red", linestyle="dashed", label="target: 50,000 moves/s batched")
    a2.set_yscale("log")
    a2.set_ylabel("moves per second")
    a2.set_title("throughput")
    a2.legend(fontsize=8)
    return save_plot(plt, fig, "service.png")


def _inside(row: dict[str, Any]) -> str:
    inside = row.get("engine_in_service_us")
    return "" if inside is None else f"; the engine's own share inside the service {inside:.1f} µs"


def service_targets(results: dict[str, Any]) -> list[str]:
    """The service's targets (against the engine, every core, memory), from this file's sections."""
    out = ["## Service targets: where each stands", "",
           "| target | measured | verdict |", "|---|---|---|"]
    svc = results.get("service") or {}
    batches = svc.get("batch_workload")
    if batches:
        eng = batches["engine"]
        bare = batches.get("bare")
        # the bound: the engine alone behind a bare queryable, sent by the raw clients, in the same rounds
        bound = (f"; the bound, the engine alone behind a bare queryable: {bare['moves_per_s']:,.0f} moves/s, "
                 f"{bare['ratio_to_engine']:.2f} (rounds " + ", ".join(f"{r['ratio_to_engine']:.2f}"
                                                            for r in bare.get("rounds") or [bare]) + ")"
                 if bare else "")
        unreachable = bool(bare) and bare["ratio_to_engine"] < 0.8
        for row in batches["service"]:
            met = row["ratio_to_engine"] >= 0.8
            out.append(f"| batched throughput ≥ 0.8 of `World.move` in process, same movers and moves ({row['form']}) "
                       f"| {row['moves_per_s']:,.0f} vs {eng['moves_per_s']:,.0f} moves/s: {row['ratio_to_engine']:.2f} "
                       f"({row['cpu_ratio_to_engine']:.2f} in CPU per move: {row['service_cpu_us_per_move']:.1f} vs "
                       f"{eng['cpu_us_per_move']:.1f} µs{_inside(row)}){bound if row['form'] == RAW_COLUMNS_FORM else ''} "
                       f"| {'met' if met else 'missed'}"
                       f"{' (the bound too: not reachable on this machine)' if not met and unreachable else ''} |")
    lat = svc.get("latency")
    if lat:
        r = lat["ratio_move_to_echo"]
        bound = lat.get("ratio_engine_echo_to_echo")
        beyond = (f"; the bound, the engine alone behind a bare queryable: {lat['engine_echo']['median']:.0f} µs, "
                  f"{bound:.2f}x" if bound is not None else "")
        out.append(f"| one-move round trip ≤ 1.2x the bare Zenoh echo, interleaved | {lat['move']['median']:.0f} vs "
                   f"{lat['echo']['median']:.0f} µs: {r:.2f}x{beyond} | {'met' if r <= 1.2 else 'missed'}"
                   f"{' (the bound too: not reachable on this machine)' if r > 1.2 and bound and bound > 1.2 else ''} |")
    out += _bus_floor_targets(results)
    workers = {w["workers"]: w for w in svc.get("workers") or []}
    if 1 in workers and len(workers) > 1:
        one = workers[1]
        for n, w in sorted(workers.items()):
            if n == 1:
                continue
            ratio = w["moves_per_s"] / one["moves_per_s"]
            out.append(f"| {n} workers ≥ {0.8 * n:.1f}x one worker's throughput where {n} cores are free | "
                       f"{w['moves_per_s']:,.0f} vs {one['moves_per_s']:,.0f} moves/s: {ratio:.2f}x, the service using "
                       f"{w['service_cores']:.2f} vs {one['service_cores']:.2f} cores and the clients "
                       f"{w['client_cores']:.2f} of the same 2 CPUs | not shown here: no free cores (section 3 gives "
                       "the command for a bigger machine) |")
    mem = results.get("memory")
    if mem and mem["rows"]:
        m = mem["rows"][0]
        g = m["growth_after_first_minute_pct"]
        if g is None:
            out.append("| RSS flat (within 10 %) after the first minute of a bulk-client soak | the soak ended within a "
                       "minute | not measured |")
        else:
            out.append(f"| RSS flat (within 10 %) after the first minute of a bulk-client soak | "
                       f"{m['rss_after_first_minute_mib']:.0f} MiB after a minute, {m['rss_end_mib']:.0f} MiB after "
                       f"{m['moves']:,} moves and {m['sessions']} client sessions: {g:+.1f} % | "
                       f"{'met' if abs(g) <= 10.0 else 'missed'} |")
    return out + [""] if len(out) > 4 else []


#: the service at the bus's floor: its own work in a column batch (instructions a move), what it and the client
#: library add to one move's round trip over the engine behind a bare queryable (µs), and the column batch's
#: throughput with raw clients as a share of that bound's
COLUMN_PATH_MAX_INSTRUCTIONS = 2_500
ROUND_TRIP_MAX_OVER_BOUND_US = 40.0
RAW_COLUMNS_MIN_SHARE_OF_BOUND = 0.95


def _floor_note(lat: dict[str, Any], bound: float) -> str:
    """What bounds the one-move target from below, measured in the same run (benchmarks/service_floor.py):
    a lean handler in a service node's process, on a literal key and on a wildcard one, and that node's
    own move key, each over the bound."""
    if not all(k in lat for k in ("floor_exact", "floor_wild", "floor_move")):
        return ""
    exact, wild, own = (lat[k]["median"] - bound for k in ("floor_exact", "floor_wild", "floor_move"))
    return (f"; against the bound, in a service node's process, a lean handler (decode, engine, pack, reply) took "
            f"{exact:+.0f} µs on a literal key and {wild:+.0f} µs on a wildcard key like the service's, and that "
            f"node's own move key {own:+.0f} µs")


def _every_order_note(lat: dict[str, Any]) -> str:
    """The bound, the raw request and one move asked one request at a time in every order, in the same run."""
    every_order = lat.get("every_order") or {}
    if not all(k in every_order for k in ("engine_echo", "raw_move", "move")):
        return ""
    bound, raw, move = (every_order[k]["median"] for k in ("engine_echo", "raw_move", "move"))
    return (f" Asked one request at a time instead (the bound, the raw request and `Client.move`, their "
            f"order going through all six permutations, so that each follows each of the others equally often), the "
            f"same three took {bound:.0f}, {raw:.0f} and {move:.0f} "
            f"µs: the service {raw - bound:+.0f} µs over the bound and the client library {move - raw:+.0f} µs more. "
            "In blocks each series keeps its own offset (its code warm, the scheduler settled, always the same "
            "block before it); asking in every order removes it, and the bound, no longer run 100 times in a row, comes "
            "out slower.")


def _floor_walk(lat: dict[str, Any], bound: float) -> str:
    """From the bound to one move, step by step, as measured in the same run (benchmarks/service_floor.py)."""
    if not all(k in lat for k in ("floor_exact", "floor_wild", "floor_move", "raw_move", "move")):
        return ""
    exact, wild, own, raw, move = (lat[k]["median"] for k in ("floor_exact", "floor_wild", "floor_move", "raw_move", "move"))
    return (f" Step by step from the bound, in the same run: the same move answered inside a service node's process "
            f"by a lean handler (the service's own reader and State packer, `World.move`, the reply; nothing else) "
            f"took {exact - bound:+.0f} µs on a literal key and {wild - exact:+.0f} µs more on a key declared with a "
            f"wildcard, as the service's `P/lb/*/move` is (Zenoh's dispatch, the queried key declared on the session "
            f"as the node declares the keys it is asked on); that node's own move path took "
            f"{own - wild:+.0f} µs more than the lean handler in the same process (the key's check, the stats, "
            f"the queue and the engine lock, the error handling: small steps each, which "
            f"after an idle gap cost far more than their instructions); the `python -m service` process answered "
            f"the same raw request in {raw - bound:+.0f} µs over the bound, and the client library added "
            f"{move - raw:+.0f} µs (the Move packed, the State read into a MoverState).")


def _counted_note(results: dict[str, Any]) -> str:
    """The same round trip counted, the whole stack in one process (section 6), when the run counted it."""
    counted = (results.get("instructions") or {}).get("round_trip") or []
    if not counted:
        return ""
    c = counted[0]
    floor = ("" if "floor" not in c else
             f"; the protocol's floor, counted the same way, {c['floor_over_bound']:+,.0f} over the bound, so that "
             f"the service's and the client library's own work is {c['client_over_floor']:+,.0f}")
    return (f"; counted (callgrind, section 6), `Client.move`'s whole round trip is {c['client']:,.0f} instructions "
            f"against the bound's {c['bound']:,.0f}: {c['client_over_bound']:+,.0f}{floor}")


def _bus_floor_targets(results: dict[str, Any]) -> list[str]:
    """The rows of the targets at the bus's floor, each against its bound measured in the same run."""
    out: list[str] = []
    counted = (results.get("instructions") or {}).get("column_path") or []
    if counted:
        rest = counted[0]["rest_per_move"]
        out.append(f"| the service's own work in a column batch of 100 ≤ {COLUMN_PATH_MAX_INSTRUCTIONS:,} instructions a "
                   f"move (callgrind, section 6) | {rest:,.0f} (run_batch {counted[0]['run_batch_per_move']:,.0f}) | "
                   f"{'met' if rest <= COLUMN_PATH_MAX_INSTRUCTIONS else 'missed'} |")
    svc = results.get("service") or {}
    lat = svc.get("latency") or {}
    if "engine_echo" in lat and "raw_move" in lat:
        bound, raw, move = (lat[k]["median"] for k in ("engine_echo", "raw_move", "move"))
        over = move - bound
        blocks = (f"{move:.0f} vs {bound:.0f} µs: {over:.0f} µs over (the service {raw - bound:.0f} µs, raw Zenoh to it "
                  f"{raw:.0f} µs; the client library {move - raw:.0f} µs)")
        every_order = lat.get("every_order") or {}
        if all(k in every_order for k in ("engine_echo", "raw_move", "move")):
            # the verdict is the every-order figure's: blocks carry each series' own offset (benchmarks/common.py, round_trips_in_every_order)
            r_bound, r_raw, r_move = (every_order[k]["median"] for k in ("engine_echo", "raw_move", "move"))
            over = r_move - r_bound
            measured = (f"{r_move:.0f} vs {r_bound:.0f} µs, one request at a time in every order: {over:.0f} µs over (the "
                        f"service {r_raw - r_bound:.0f} µs, the client library {r_move - r_raw:.0f} µs); in blocks of "
                        f"the same run, {blocks}")
        else:
            measured = blocks
        launches = lat.get("launches")
        if launches:
            # and of several launches, when measured: one launch's figure is one draw (benchmarks/round_trip_launches.py)
            over = launches["over_bound"]["median"]
            measured = f"{launches_measured(lat)}; in the run's own launch, {measured}"
        out.append(f"| one move's round trip: the service and the client library add ≤ {ROUND_TRIP_MAX_OVER_BOUND_US:.0f} "
                   f"µs over the engine behind a bare queryable, interleaved | {measured}{_floor_note(lat, bound)}"
                   f"{_counted_note(results)} | {'met' if over <= ROUND_TRIP_MAX_OVER_BOUND_US else 'missed'} |")
    batches = svc.get("batch_workload") or {}
    bare = batches.get("bare")
    raw_rows = [r for r in batches.get("service") or [] if r["form"] == RAW_COLUMNS_FORM]
    paired = batches.get("paired")
    if paired:  # the figure the target is read from: each pair of windows half a second apart
        ratios = paired["pair_ratios"]
        q1, _, q3 = statistics.quantiles(ratios, n=4) if len(ratios) >= 2 else ratios * 3
        share = paired["ratio"]
        rounds_note = ""
        if bare and raw_rows:
            rounds = [r["moves_per_s"] / b["moves_per_s"]
                      for r, b in zip(raw_rows[0].get("rounds") or [], bare.get("rounds") or [])]
            rounds_note = ("; in the workload's rounds, seconds apart: " + ", ".join(f"{x:.2f}" for x in rounds)
                           if rounds else "")
        out.append(f"| column batches with raw clients ≥ {RAW_COLUMNS_MIN_SHARE_OF_BOUND:.2f} of the engine behind a bare "
                   f"queryable, in {paired['window_s']:g} s windows paired with the bound's | "
                   f"{paired['service_moves_per_s']:,.0f} vs {paired['bare_moves_per_s']:,.0f} moves/s: {share:.2f}, the "
                   f"median of {len(ratios)} pairs' ratios (quartiles {q1:.2f}-{q3:.2f}){rounds_note} | "
                   f"{'met' if share >= RAW_COLUMNS_MIN_SHARE_OF_BOUND else 'missed'} |")
    elif bare and raw_rows:
        row = raw_rows[0]
        share = row["moves_per_s"] / bare["moves_per_s"]
        rounds = [r["moves_per_s"] / b["moves_per_s"] for r, b in zip(row.get("rounds") or [], bare.get("rounds") or [])]
        out.append(f"| column batches with raw clients ≥ {RAW_COLUMNS_MIN_SHARE_OF_BOUND:.2f} of the engine behind a bare "
                   f"queryable, same rounds | {row['moves_per_s']:,.0f} vs {bare['moves_per_s']:,.0f} moves/s: {share:.2f}"
                   + (" (rounds " + ", ".join(f"{x:.2f}" for x in rounds) + ")" if rounds else "")
                   + f" | {'met' if share >= RAW_COLUMNS_MIN_SHARE_OF_BOUND else 'missed'} |")
    return out


def client_label(r: dict[str, Any]) -> str:
    mode = r.get("client", "objects")
    what = "replies decoded to MoverState objects" if mode == "objects" else "replies read as maps (lean client)"
    if not r.get("watched"):
        return what + "; no State subscriber"
    return what + ("; a subscriber receiving every State, one publication per request (publish: batch)"
                   if r.get("publish") == "batch" else "; a subscriber receiving every State, one publication per move")


def _throughput_table(rows: list[dict[str, Any]]) -> list[str]:
    out = ["| client processes | moves per request | client reads replies as | State subscriber | publish | moves/s "
           "| service CPU µs per move | client CPU µs per move | errors |",
           "|---:|---:|---|---|---|---:|---:|---:|---:|"]
    for r in rows:
        sub = "no"
        if r.get("watched"):
            sub = f"yes ({r['states_received']:,} received)" if r.get("states_received") is not None else "yes"
        mode = r.get("client", "objects")
        out.append(f"| {r['processes']} | {r['batch']} | {'MoverState' if mode == 'objects' else 'maps'} | {sub} "
                   f"| {r.get('publish', 'each')} "
                   f"| {r['moves_per_s']:,.0f} | {num(r['service_cpu_us_per_move'], 0)} "
                   f"| {num(r.get('client_cpu_us_per_move'), 0)} | {r['errors']} |")
    return out


_THROUGHPUT_TEXT = (
    "Throughput: each client process registers its own mover and sends requests back to back for a fixed time; "
    "service CPU time per move is the service process's user+system time (from /proc) over the moves served, "
    "client CPU the client processes' own. Batches are sent either with `Client.move_many` (every entry decoded "
    "into a MoverState) or with `Client.move_many_maps` (the reply's msgpack decoded into maps; the client counts "
    "error entries and learns each mover's landblock, nothing more). The service publishes a move's State only "
    "while someone subscribes to a state key (docs/protocol.md, State publication): the rows without a State "
    "subscriber have nobody subscribed, so no State is published; the rows with one run a subscriber process on "
    "every state key and on `P/states`, which receives (and counts) every State. `publish`: the requests' field, "
    "`each` (the default: one publication per move on its mover's key) or `batch` (one message per request on "
    "`P/states`).")


WORKERS_TEXT = (
    "One service with 1 and 2 engine processes (`acphys serve --workers N`: a Zenoh router in the parent, the "
    "landblocks split between the workers), the same batched workload: 4 client processes, batches of 100 moves "
    "read as maps, no State subscriber, the movers spread over two landblocks that 2 workers serve apart. CPU in "
    "cores: CPU seconds per second of the run, the service's (parent and workers, from /proc) and the clients' "
    "(their own). Clients and service share this machine's cores, so the row with 2 workers cannot show the "
    "scaling a machine with spare cores gives; `python3 -m benchmarks.bench_service workers --workers 1,2,4 "
    "--clients 8` repeats it (clients on other machines show it best).")


def spanning_text(sp: dict[str, Any]) -> list[str]:
    """The batch over two workers' landblocks (benchmarks/bench_spanning.py)."""
    return [
        f"A batch over two workers' landblocks (`--workers 2`, {sp['movers_each']} movers in each of "
        f"{', '.join(f'{lb:04X}' for lb in sp['landblocks'])}, every mover out and back: {sp['moves']} moves, one "
        f"client, {sp['rounds']} round trips each way, interleaved): `Client.move_batch` sends both landblocks' "
        f"requests before it reads either reply, **{sp['together_us']:,.0f} µs** at the median; the same two requests "
        f"one after the other (each reply read before the next request is sent) {sp['apart_us']:,.0f} µs: "
        f"**{sp['ratio']:.2f}x**. The two engines work at the same time on this machine's two CPUs, which the client "
        f"shares. {sp['errors']} errors.",
    ]


def workers_table(rows: list[dict[str, Any]]) -> list[str]:
    """The `--workers` rows: throughput and each side's CPU use."""
    out = ["| engine processes | client processes | moves/s | service CPU, cores | client CPU, cores "
           "| service CPU µs per move | errors |", "|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        out.append(f"| {r['workers']} | {r['processes']} | {r['moves_per_s']:,.0f} | {r['service_cores']:.2f} "
                   f"| {r['client_cores']:.2f} | {num(r['service_cpu_us_per_move'], 0)} | {r['errors']} |")
    return out


def _handling(lat: dict[str, Any]) -> list[str]:
    """The service's handling of one move without the network, back to back and after idle gaps."""
    hd = lat.get("handling_us")
    if not hd:
        return []
    out = ["", ("One move handled by the service without the network (its query callback called with a stand-in "
                "query, in a child process), back to back and after an idle gap before each move:"), "",
           "| gap before each move | handler median µs | engine median µs | handler p99 µs |", "|---|---:|---:|---:|"]
    for k, label in (("gap_0us", "none"), ("gap_400us", "0.4 ms"), ("gap_2000us", "2 ms")):
        if k in hd:
            h, e = hd[k]["handler"], hd[k]["engine"]
            out.append(f"| {label} | {h['median']:.0f} | {e['median']:.0f} | {h['p99']:.0f} |")
    if "no_engine" in hd:
        h = hd["no_engine"]["handler"]
        out.append(f"| none, the engine replaced by a stand-in (the service's own part) | {h['median']:.1f} | - | "
                   f"{h['p99']:.0f} |")
    if "client" in hd:
        h = hd["client"]["handler"]
        out.append(f"| none: the client library's part (`Client.move`, stand-in session) | {h['median']:.1f} | - | "
                   f"{h['p99']:.0f} |")
    return out + _versus_floor(hd.get("versus_floor"))


def _versus_floor(vf: dict[str, Any] | None) -> list[str]:
    """The service's callback against the protocol's floor in the same process, warm and after an idle gap."""
    if not vf or "gap_0us" not in vf or "gap_400us" not in vf:
        return []
    warm, idle = vf["gap_0us"], vf["gap_400us"]

    def over(both: dict[str, Any]) -> float:
        return float(both["service"]["median"] - both["floor"]["median"])

    return ["", (f"The same callback and the protocol's floor (benchmarks/service_floor.py's lean handler on the same "
                 f"records: the request read, `World.move`, the State packed, the reply; nothing else), asked one "
                 f"after the other, each first in turn: back to back {warm['service']['median']:.1f} against "
                 f"{warm['floor']['median']:.1f} µs, the service's own steps {over(warm):+.1f} µs; with 0.4 ms of "
                 f"idling before each, as in a round trip, {idle['service']['median']:.1f} against "
                 f"{idle['floor']['median']:.1f} µs, {over(idle):+.1f} µs. After the gap the floor ran "
                 f"{idle['floor']['median'] / warm['floor']['median']:.1f} times slower and the service's callback "
                 f"{idle['service']['median'] / warm['service']['median']:.1f} times: every step runs several times "
                 "slower after idling, so each step the service adds over the protocol's costs a round trip several "
                 f"times its warm cost ({over(idle) / over(warm):.1f} times, all told)." if over(warm) > 0 else
                 f"The same callback and the protocol's floor, asked one after the other: back to back "
                 f"{warm['service']['median']:.1f} against {warm['floor']['median']:.1f} µs; with 0.4 ms of "
                 f"idling before each, {idle['service']['median']:.1f} against {idle['floor']['median']:.1f} µs.")]


def _run_batch_note(eng: dict[str, Any]) -> str:
    """The engine's own batch entry point on the same moves, where the run measured it."""
    rb = eng.get("run_batch")
    if not rb:
        return ""
    return (f"; the engine's batch entry point (`engine.world.batch.run_batch`, batches of 100 as the clients send "
            f"them) {rb['moves_per_s']:,.0f} moves/s, {rb['cpu_us_per_move']:.1f} µs of CPU per move")


def _bare_note(bare: dict[str, Any] | None, cols: dict[str, Any]) -> str:
    """What the engine behind a bare queryable says of the bus (the service targets' bound)."""
    if not bare:
        return ""
    return (f" The same engine behind a bare Zenoh queryable, with nothing else per request, carried "
            f"{bare['moves_per_s']:,.0f} moves/s ({bare['ratio_to_engine']:.2f} of the engine in process) at "
            f"{bare['service_cpu_us_per_move']:.1f} µs of CPU per move, in the same rounds: as far as one engine "
            "thread behind this bus goes on this machine (the engine, Zenoh's receive and reply, and the clients "
            "on the same two cores). The service's own work per request (decoding, checks, records, stats, the "
            f"reply's columns) costs {cols['service_cpu_us_per_move'] - bare['service_cpu_us_per_move']:.1f} µs per "
            f"move more, on the thread that runs the engine, and takes the column form from the bound's "
            f"{bare['ratio_to_engine']:.2f} to {cols['ratio_to_engine']:.2f}.")


def _batch_workload(data: dict[str, Any] | None, label: str) -> list[str]:
    """The batch workload through the map and the column batch, beside World.move in process."""
    if not data or "engine" not in data:
        return []
    eng = data["engine"]
    rounds = data.get("rounds", 1)
    how = (f"in {rounds} rounds of {data.get('seconds_each', 0):.0f} s each (World.move, then each form), "
           "medians over the rounds" if rounds > 1 else "in one round")
    out = ["", (f"The batch workload of benchmarks/bench_batches.py ({label}): {data['movers']} player movers one "
                f"every {data['spacing_m']:.0f} m on "
                f"the demo world walking ±{data['step_m']} m, two client processes each moving its half in batches of "
                "100 (every mover out and back), by map batch (`Client.move_many_maps`), by column batch "
                "(`Client.move_batch`, docs/protocol.md, Column batches) and by the same column request's bytes sent "
                "with raw Zenoh gets, each reply decoded with msgpack and its error list read (\"columns, raw "
                "clients\": the raw Zenoh + msgpack clients the target is read with, and the bound's clients, so that "
                "the client library's CPU on the same two cores is not counted against the service); beside it "
                "`World.move` on the same movers in "
                f"a process of its own, {how}: {eng['moves_per_s']:,.0f} moves/s, "
                f"{eng['cpu_us_per_move']:.1f} µs of CPU per move{_run_batch_note(eng)}. \"The engine inside the "
                "service\" is the service's own mean engine time per move (Stats `engine_ms`) while the clients run: "
                "the same engine code, slowed by the clients and Zenoh sharing this machine's two cores; the column "
                "after it is the rest of the service's CPU per move (decoding, checks, stats, encoding, Zenoh)."), "",
           "| batch form | moves/s | service CPU µs per move | the engine inside the service, µs per move | "
           "service CPU beyond its engine, µs per move | client CPU µs per move | moves/s / engine's | "
           "engine's CPU per move / service's | errors |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    bare = data.get("bare")
    for r in [*data["service"], *([bare] if bare else [])]:
        inside, beyond = r.get("engine_in_service_us"), r.get("service_beyond_engine_us")
        out.append(f"| {r['form']} | {r['moves_per_s']:,.0f} | {r['service_cpu_us_per_move']:.1f} | "
                   f"{'-' if inside is None else f'{inside:.1f}'} | {'-' if beyond is None else f'{beyond:.1f}'} | "
                   f"{r['client_cpu_us_per_move']:.1f} | {r['ratio_to_engine']:.2f} | {r['cpu_ratio_to_engine']:.2f} | "
                   f"{r['errors']} |")
    per_round = [f"{r['form']} " + ", ".join(f"{x['ratio_to_engine']:.2f}" for x in r["rounds"])
                 for r in [*data["service"], *([bare] if bare else [])] if len(r.get("rounds") or []) > 1]
    if per_round:
        out += ["", "Each round's moves/s ratio: " + "; ".join(per_round) + "."]
    if bare:
        out += ["", (f"The last row is a bound, not a form: \"{bare['form']}\" is a bare Zenoh queryable in a process "
                     "of its own that, for each request, runs the sending client's batch through `run_batch` on the "
                     "same movers and answers with as many bytes as the service's column reply, nothing decoded, "
                     "checked or encoded; the two client processes send the column request's bytes with raw Zenoh "
                     "gets and read the reply's bytes only. It is what this bus carries when the engine is the only "
                     "work per request, on the same machine in the same rounds.")]
    return out


def service_section(svc: dict[str, Any], plot: str | None) -> list[str]:
    out = ["## 3. Service over loopback", "", meta_line(svc), ""]
    if "latency" not in svc:
        return out + [f"Not measured: {svc.get('failed')}", ""]
    lat = svc["latency"]
    svc_compiled = svc.get("meta", {}).get("machine", {}).get("compiled_engine_modules")
    out += [f"First the service on the working tree's engine ({'compiled' if svc_compiled else 'interpreted'}).", ""]
    out += [("`python -m service` on a flat 3x3-landblock scene, `clients.Client` in this process; the floor is a bare "
            "Zenoh queryable in its own process answering with the request's bytes "
            f"({lat['probe_bytes']} bytes, the size of a one-move request), queried the same way in the same run, "
            "interleaved block by block with the service round trips. Peer mode, TCP on 127.0.0.1, multicast scouting off. "
            "The bound for one move is another bare queryable in its own process that only runs the engine "
            "(`engine_echo_main` in benchmarks/bench_service.py): it reads the one-move request with msgpack, checks "
            "nothing, moves one mover of the same walker on the same scene with `World.move` and answers with the "
            "result's cell, origin, orientation and contact bits in one msgpack array: the least any service of this "
            "engine does per move on this bus."), "",
            "| round trip | n | median µs | p99 µs | median µs per move |", "|---|---:|---:|---:|---:|"]
    for k, label, per in (("echo", "bare Zenoh echo", 1),
                          ("engine_echo", "one move, the engine alone behind a bare queryable (the bound)", 1),
                          ("health", "health (a bare get the service answers with no engine)", 1),
                          ("floor_exact", "one move, a lean handler in a service node's process, literal key "
                           "(benchmarks/service_floor.py)", 1),
                          ("floor_wild", "the same lean handler declared on a wildcard key, as the service's keys are", 1),
                          ("floor_move", "that node's own move key: the service's whole path, in the same process", 1),
                          ("raw_move", "one move as a bare get (no client library)", 1), ("move", "one move", 1),
                          ("accounts_move", "one move, a logged-in user of a service run with `--users`", 1),
                          ("batch10", "batch of 10 moves", 10), ("batch100", "batch of 100 moves", 100)):
        if k not in lat:  # results saved before the row was measured
            continue
        s = lat[k]
        out.append(f"| {label} | {s['n']} | {s['median']:.0f} | {s['p99']:.0f} | {s['median'] / per:.0f} |")
    out += _handling(lat)
    eng_ms = lat.get("service_engine_ms") or {}
    out += ["", (f"One move / echo: **{lat['ratio_move_to_echo']:.2f}x** at the median "
            f"({lat['ratio_move_to_echo_p99']:.2f}x at p99). Inside the service the engine took "
            f"{num(as_float(eng_ms.get('p50')) * 1000, 0)} µs per move at the median (its own stats)."
            + (f" With accounts (a second service of the same world, run with `--users`: Zenoh's authentication and "
               f"access control on every message, the user's own tenant) one move took "
               f"**{lat['ratio_accounts_move_to_move']:.2f}x** the plain one's round trip at the median, "
               f"interleaved in the same run." if "ratio_accounts_move_to_move" in lat else "")), "",
            _THROUGHPUT_TEXT, "", *_throughput_table(svc["throughput"])]
    out += _batch_workload(svc.get("batch_workload"), "the working tree's engine")
    if svc.get("workers"):
        out += ["", WORKERS_TEXT, "", *workers_table(svc["workers"])]
    if svc.get("spanning"):
        out += ["", *spanning_text(svc["spanning"])]
    comp = svc.get("compiled")
    if comp and "latency" in comp:
        cl = comp["latency"]
        out += ["", ("The same benchmark again in the same run, the service importing the mypyc-compiled engine copy "
                     "(benchmarks/out/compiled):"), "",
                "| round trip | median µs | p99 µs |", "|---|---:|---:|"]
        for k, label in (("echo", "bare Zenoh echo"), ("move", "one move"), ("batch10", "batch of 10 moves"),
                         ("batch100", "batch of 100 moves")):
            out.append(f"| {label} | {cl[k]['median']:.0f} | {cl[k]['p99']:.0f} |")
        out += _handling(cl)
        ce = as_float((cl.get("service_engine_ms") or {}).get("p50")) * 1000.0
        out += ["", f"One move / echo: **{cl['ratio_move_to_echo']:.2f}x**; engine {num(ce, 0)} µs per move inside the service.", "",
                *_throughput_table(comp["throughput"])]
        out += _batch_workload(comp.get("batch_workload"), "compiled engine")
    elif comp:
        out += ["", f"The compiled-engine service run failed: {comp.get('failed')}"]
    if plot:
        out += ["", f"![service]({plot})"]
    return out + [""]


def memory_section(mem: dict[str, Any]) -> list[str]:
    out = ["## Memory: the service under reconnecting bulk clients", "", meta_line(mem), "",
           (f"Client sessions two at a time, each its own process with Zenoh's default configuration (shared memory "
            f"on), each registering {mem['movers_per_session']} movers, sending batches of {mem['batch']} moves "
            "(about 5 KB, over Zenoh's 3 KiB shared-memory threshold), removing its movers and leaving "
            "(benchmarks/bench_memory.py). RSS of the service process from /proc, once a second. The first row is the "
            "service as shipped; the second gives the same service a config file that turns Zenoh's shared-memory "
            "transport back on, as it ran before (service/bus/zconfig.py says why it is off)."), "",
           "| service | moves | client sessions | seconds | RSS at start | after the first minute | at the end | "
           "growth after the first minute | growth per session |",
           "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in mem["rows"]:
        label = "shared memory on (before)" if r["shared_memory"] else "as shipped (shared memory off)"
        minute = "—" if r["rss_after_first_minute_mib"] is None else f"{r['rss_after_first_minute_mib']:.0f} MiB"
        growth = "—" if r["growth_after_first_minute_pct"] is None else f"{r['growth_after_first_minute_pct']:+.1f} %"
        out.append(f"| {label} | {r['moves']:,} | {r['sessions']} | {r['seconds']:.0f} | {r['rss_start_mib']:.0f} MiB | "
                   f"{minute} | {r['rss_end_mib']:.0f} MiB | {growth} | {r['growth_per_session_mib']:.2f} MiB |")
    return out + [""]


def service_limits(results: dict[str, Any]) -> list[str]:
    """The service's bullets of "What limits each figure", from the numbers of this run."""
    out: list[str] = []
    svc = results.get("service")
    if svc and "latency" in svc:
        lat = svc["latency"]
        eng_us = as_float((lat.get("service_engine_ms") or {}).get("p50")) * 1000.0
        over = lat["move"]["median"] - lat["echo"]["median"] - (eng_us if math.isfinite(eng_us) else 0.0)
        best = max((r for r in svc["throughput"] if r["batch"] > 1), key=lambda r: r["moves_per_s"], default=None)
        txt = (f"- Service round trip: {lat['move']['median']:.0f} µs = the bare echo ({lat['echo']['median']:.0f} µs) "
               f"+ the engine ({num(eng_us, 0)} µs, the service's own median) + {over:.0f} µs of client library and "
               "service work (msgpack and the State on both sides, the reply; no State is published, nobody subscribes; the "
               "move runs in the query's callback when the engine is idle, with no hand-off to another thread). "
               f"Meeting 1.2x the echo leaves {0.2 * lat['echo']['median']:.0f} µs for all of it, the engine included.")
        hd = lat.get("handling_us") or {}
        hot, warm = hd.get("gap_0us"), hd.get("gap_400us")
        if hot and warm:
            txt += (f" Without the network the service handles one move in {hot['handler']['median']:.0f} µs back to "
                    f"back (engine {hot['engine']['median']:.0f} µs) but in {warm['handler']['median']:.0f} µs "
                    f"(engine {warm['engine']['median']:.0f} µs) when each move follows 0.4 ms of idling, as in a "
                    f"round trip: on this shared machine code runs {warm['handler']['median'] / hot['handler']['median']:.0f}x "
                    "slower after the CPU idled or ran other processes (its caches cold), and the service runs far "
                    "more code per request than the echo.")
        if "engine_echo" in lat:
            ee = lat["engine_echo"]["median"]
            txt += (f" The engine alone behind a bare queryable (msgpack in, `World.move`, msgpack out, nothing "
                    f"checked) took {ee:.0f} µs, {lat['ratio_engine_echo_to_echo']:.2f}x the echo, in the same run: "
                    f"{ee - lat['echo']['median']:.0f} µs over the echo for one engine call and two msgpack calls. "
                    f"The service and the client library add {lat['move']['median'] - ee:.0f} µs to that (the "
                    "request's checks, the record, seq and stats, the State packed and decoded; a single move's "
                    "publication check comes after its reply).")
            txt += _floor_walk(lat, ee)
            txt += _every_order_note(lat)
            txt += launches_note(lat)
        out.append(txt)
        if best and best.get("service_cpu_us_per_move"):
            cpu = best["service_cpu_us_per_move"]
            comp = svc.get("compiled") or {}
            cbest = max((r for r in comp.get("throughput", []) if r["batch"] > 1), key=lambda r: r["moves_per_s"],
                        default=None)
            ctxt = ""
            if cbest and cbest.get("service_cpu_us_per_move"):
                cc = cbest["service_cpu_us_per_move"]
                ceng = as_float((comp["latency"].get("service_engine_ms") or {}).get("p50")) * 1000.0
                ctxt = (f" With the compiled engine the service spends {cc:.0f} µs of CPU per move (the engine "
                        f"itself {num(ceng, 0)} µs of it), a ceiling of ~{1e6 / cc:,.0f} moves/s; everything in the "
                        "service but the engine is now the larger part of a move's cost.")
            both = ""
            rows_all = list(svc["throughput"]) + list(comp.get("throughput", []))
            top = max((r for r in rows_all if r["batch"] > 1 and r.get("client_cpu_us_per_move")),
                      key=lambda r: r["moves_per_s"], default=None)
            if top:
                total = top["service_cpu_us_per_move"] + top["client_cpu_us_per_move"]
                cpus = (svc.get("meta", {}).get("machine", {}) or {}).get("cpus") or 2
                both = (f" In the fastest batched run ({top['moves_per_s']:,.0f} moves/s, {client_label(top)}) a move "
                        f"cost {top['service_cpu_us_per_move']:.0f} µs of service CPU and "
                        f"{top['client_cpu_us_per_move']:.0f} µs of client CPU, {total:.0f} µs in all: on {cpus} CPUs "
                        f"that is at most ~{cpus * 1e6 / total:,.0f} moves/s with the machine to ourselves, and it "
                        "is shared with other work (see the load average above). Several instances owning "
                        "different landblocks (`--own`) would add service cores on a bigger machine; on this one "
                        "they would compete for the same CPUs as the clients, so they are not measured here.")
            out.append(f"- Service throughput: one service process spends {cpu:.0f} µs of CPU per move in batches "
                       f"of {best['batch']}, so it cannot serve more than ~{1e6 / cpu:,.0f} moves/s however many "
                       "clients send (the engine runs on one thread; Python's GIL serialises the rest); 50,000 "
                       "moves/s needs at most 20 µs per move, decoding and encoding included, or several "
                       "instances owning different landblocks." + ctxt + both)
        batches = svc.get("batch_workload") or {}
        forms = {r["form"]: r for r in batches.get("service", [])}
        # the column form with the bound's clients where measured (older runs: the client library's)
        cols = forms.get(RAW_COLUMNS_FORM) or forms.get("columns")
        if cols and cols.get("engine_in_service_us") is not None:
            eng = batches["engine"]
            need = eng["cpu_us_per_move"] / 0.8
            out.append(
                f"- Batched throughput (the batch workload): with the column form ({cols['form']}) a move cost the service "
                f"{cols['service_cpu_us_per_move']:.1f} µs of CPU, of which {cols['engine_in_service_us']:.1f} µs in "
                f"the engine (its own stats) and {cols['service_beyond_engine_us']:.1f} µs in everything else "
                "(Zenoh's receive and reply, msgpack, the column checks, the rows' bookkeeping and the reply's "
                f"arrays). In a process of its own the same engine took {eng['cpu_us_per_move']:.1f} µs per move: "
                "inside the service it shares this machine's two cores with the two client processes and "
                "Zenoh's threads. 0.8 of the engine's rate asks the whole service for at most "
                f"{need:.1f} µs per move." + _bare_note(batches.get("bare"), cols))
    return out
