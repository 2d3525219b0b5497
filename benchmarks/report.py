"""docs/performance.md and its plots, from docs/performance.json (the stored results of every section)."""

from __future__ import annotations

import math
from typing import Any

from . import common
from .common import fmt

PLOTS = common.ROOT / "benchmarks" / "plots"
REL = "../benchmarks/plots"  # from docs/


def _nan(x: Any) -> float:
    return math.nan if x is None else float(x)


def _f(x: Any, d: int = 1) -> str:
    return fmt(_nan(x), d)


def _e(x: Any) -> str:
    """An error in metres."""
    x = _nan(x)
    if math.isnan(x):
        return "n/a"
    if x == 0.0:
        return "0"
    return f"{x:.2g}"


def _pct(x: Any) -> str:
    x = _nan(x)
    return "n/a" if math.isnan(x) else f"{100.0 * x:.2f} %"


def _findings_note() -> str:
    from .stress import FINDINGS

    open_ = [w for w, t in FINDINGS if "xfail" in t]
    return f"; earlier runs found {len(open_)} open engine issue(s), see section 4" if open_ else ""


def _verdict(value: float, limit: float) -> str:
    """'met' when value <= limit, else by how many times it misses."""
    return "met" if value <= limit else f"missed by {value / limit:.1f}x"


def _ratio(x: Any) -> str:
    return "" if not x else f"{x:.1f}x"


# -- plots ------------------------------------------------------------------------------------
def _plt() -> Any:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        return plt
    except ImportError:
        return None


def plot_engine(eng: dict[str, Any]) -> str | None:
    plt = _plt()
    if plt is None:
        return None
    rows = [r for r in eng["workloads"] if "us" in r]
    trows = eng["traces"]
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.5))
    names = [r["name"] for r in rows]
    med = [r["us"]["median"] for r in rows]
    p99 = [r["us"]["p99"] for r in rows]
    xs = range(len(rows))
    a1.bar([x - 0.2 for x in xs], med, 0.4, label="median")
    a1.bar([x + 0.2 for x in xs], p99, 0.4, label="p99", alpha=0.6)
    for x, r in zip(xs, rows):
        if r.get("target_us"):
            a1.hlines(r["target_us"], x - 0.45, x + 0.45, colors="red", linestyles="dashed")
    var = eng.get("variant") or {}
    vlabel = {"compiled": "compiled (mypyc) median", "pure": "pure Python median"}.get(var.get("kind", ""), "")
    vw = {r["name"]: r["us"]["median"] for r in var.get("workloads", []) if "us" in r} if not var.get("failed") else {}
    vt = {r["name"]: r["us"]["median"] for r in var.get("traces", []) if "us" in r} if not var.get("failed") else {}
    if vw:
        pts = [(x, vw[r["name"]]) for x, r in zip(xs, rows) if r["name"] in vw]
        a1.scatter([x - 0.2 for x, _ in pts], [v for _, v in pts], marker="D", color="tab:green", zorder=3, label=vlabel)
    a1.set_yscale("log")
    a1.set_xticks(list(xs), names, rotation=30, ha="right")
    a1.set_ylabel("µs per move")
    a1.set_title("synthetic workloads (RETAIL); red: issue 6 target")
    a2.set_title("reference traces replayed (ACE_COMPAT)")
    a1.legend()
    tn = [r["name"] for r in trows]
    tm = [r["us"]["median"] for r in trows]
    xs2 = range(len(trows))
    a2.bar(list(xs2), tm, 0.5, label="acphys median")
    anchors = [(x, r["anchor_us"]) for x, r in zip(xs2, trows) if r.get("anchor_us")]
    if anchors:
        a2.scatter([x for x, _ in anchors], [a for _, a in anchors], color="black", marker="_", s=400, label="ACE (Mono)")
    if vt:
        pts = [(x, vt[r["name"]]) for x, r in zip(xs2, trows) if r["name"] in vt]
        a2.scatter([x for x, _ in pts], [v for _, v in pts], marker="D", color="tab:green", zorder=3, label=vlabel)
    a2.set_yscale("log")
    a2.set_xticks(list(xs2), tn, rotation=30, ha="right")
    a2.set_ylabel("µs per move (median)")
    a2.set_title("reference traces replayed (ACE_COMPAT)")
    a2.legend()
    fig.tight_layout()
    PLOTS.mkdir(parents=True, exist_ok=True)
    fig.savefig(PLOTS / "engine.png", dpi=90)
    plt.close(fig)
    return f"{REL}/engine.png"


def plot_error(err: dict[str, Any]) -> str | None:
    plt = _plt()
    if plt is None:
        return None
    rows = [r for r in err["settings"] if r["moves"]]
    front = set(err.get("pareto", []))
    floor = 1e-7
    fig, ax = plt.subplots(figsize=(8, 5))
    for r in rows:
        x, y = _nan(r["us_mean"]), max(floor, _nan(r["err_ref"]["p99"]))
        on = r["name"] in front
        ax.scatter([x], [y], s=70 if on else 40, color="tab:red" if on else "tab:blue", zorder=3)
        ax.annotate(r["name"], (x, y), textcoords="offset points", xytext=(6, 4), fontsize=8)
    pts = sorted((_nan(r["us_mean"]), max(floor, _nan(r["err_ref"]["p99"]))) for r in rows if r["name"] in front)
    if len(pts) > 1:
        ax.step([p[0] for p in pts], [p[1] for p in pts], where="post", color="tab:red", alpha=0.5, label="Pareto front")
    ax.axhline(1e-4, color="green", linestyle="dashed", label="target: most exact p99 ≤ 1e-4 m")
    ax.axhline(1e-3, color="orange", linestyle="dashed", label="target: fastest on front ≤ 1e-3 m")
    ax.set_yscale("log")
    ax.set_xlabel("run time, µs per move (mean over the reference traces)")
    ax.set_ylabel("p99 final-position error against the reference (m)")
    ax.set_title("run time against error, one point per engine setting")
    ax.legend(fontsize=8)
    fig.tight_layout()
    PLOTS.mkdir(parents=True, exist_ok=True)
    fig.savefig(PLOTS / "error_pareto.png", dpi=90)
    plt.close(fig)
    return f"{REL}/error_pareto.png"


def plot_service(svc: dict[str, Any]) -> str | None:
    plt = _plt()
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
    fig.tight_layout()
    PLOTS.mkdir(parents=True, exist_ok=True)
    fig.savefig(PLOTS / "service.png", dpi=90)
    plt.close(fig)
    return f"{REL}/service.png"


# -- the document ---------------------------------------------------------------------------
def _meta(sec: dict[str, Any]) -> str:
    m = sec.get("meta", {})
    mach = m.get("machine", {})
    return (f"Measured by `{m.get('command', '?')}` at {m.get('started', '?')} on commit {m.get('commit', '?')} "
            f"({mach.get('cpus', '?')} CPUs, {mach.get('cpu', '?')}, Python {mach.get('python', '?')}; "
            f"load average at start {', '.join(f'{x:.2f}' for x in mach.get('loadavg_at_start', []))}); "
            f"took {m.get('seconds', 0):.0f} s{' (quick run)' if m.get('quick') else ''}. "
            + (f"The working tree's engine ran compiled ({len(mach['compiled_engine_modules'])} modules)."
               if mach.get("compiled_engine_modules") else "The working tree's engine ran interpreted (no compiled modules)."))


def _summary(results: dict[str, Any]) -> list[str]:
    out = ["## Targets of issue 6: where each stands", "",
           "| target | measured | verdict |", "|---|---|---|"]
    eng = results.get("engine")
    if eng:
        var = eng.get("variant") or {}
        vkind = var.get("kind") if var and not var.get("failed") else None
        vt = {r["name"]: r["us"]["median"] for r in var.get("traces", []) if "us" in r} if vkind else {}
        vw = {r["name"]: r["us"]["median"] for r in var.get("workloads", []) if "us" in r} if vkind else {}
        tree = "interpreted" if vkind == "compiled" else ("compiled" if vkind == "pure" else "")

        def both(med: float, other: float | None, lim: float, anchor: float | None = None) -> tuple[str, str]:
            txt = f"{med:.1f} µs median" + (f" {tree}" if tree else "")
            if anchor:
                txt += f" ({med / anchor:.1f}x ACE)"
            verdict = _verdict(med, lim)
            if other:
                txt += f"; {other:.1f} µs {vkind}" + (f" ({other / anchor:.1f}x ACE)" if anchor else "")
                best = min(med, other)
                verdict = _verdict(best, lim) + (" (best build)" if tree else "")
            return txt, verdict

        for r in eng["traces"]:
            if r.get("anchor_us"):
                lim = min(15.0, 2 * r["anchor_us"])
                txt, verdict = both(r["us"]["median"], vt.get(r["name"]), lim, r["anchor_us"])
                out.append(f"| terrain trace `{r['name']}`: ≤ {lim:g} µs/move (15 µs and 2x ACE's {r['anchor_us']} µs) "
                           f"| {txt} | {verdict} |")
        for r in eng["workloads"]:
            if "us" in r and r.get("target_us"):
                txt, verdict = both(r["us"]["median"], vw.get(r["name"]), r["target_us"])
                out.append(f"| workload `{r['name']}`: ≤ {r['target_us']:g} µs/move | {txt} | {verdict} |")
            elif "unavailable" in r:
                out.append(f"| workload `{r['name']}` | not measured: {r['unavailable']} | gap |")
    err = results.get("error")
    if err and err["settings"]:
        ref = err["settings"][0]
        p99 = _nan(ref["err_ref"]["p99"])
        wk = ref.get("err_ref_without_known") or {}
        extra = f" ({_e(wk.get('p99'))} m without the known divergent cases)" if wk.get("moves") else ""
        out.append(f"| most exact setting (`{ref['name']}`): p99 error ≤ 1e-4 m | {_e(p99)} m{extra} "
                   f"| {'met' if p99 <= 1e-4 else f'missed ({p99 / 1e-4:.1f}x)'} |")
        front = [r for r in err["settings"] if r["name"] in err.get("pareto", [])]
        if front:
            fastest = min(front, key=lambda r: _nan(r["us_mean"]))
            fp = _nan(fastest["err_ref"]["p99"])
            out.append(f"| fastest setting on the Pareto front (`{fastest['name']}`): p99 ≤ 1e-3 m | {_e(fp)} m "
                       f"| {'met' if fp <= 1e-3 else 'missed'} |")
    svc = results.get("service")
    if svc and "latency" in svc:
        lat = svc["latency"]
        ratio = lat["ratio_move_to_echo"]
        comp = svc.get("compiled") or {}
        cl = comp.get("latency")
        extra = (f"; compiled engine: {cl['move']['median']:.0f} µs vs {cl['echo']['median']:.0f} µs, "
                 f"{cl['ratio_move_to_echo']:.2f}x") if cl else ""
        best_ratio = min(ratio, cl["ratio_move_to_echo"]) if cl else ratio
        out.append(f"| service round trip of one move ≤ 1.2x bare Zenoh echo | {lat['move']['median']:.0f} µs vs "
                   f"{lat['echo']['median']:.0f} µs echo: {ratio:.2f}x{extra} | {'met' if best_ratio <= 1.2 else 'missed'} |")
        rows_all = list(svc["throughput"]) + list(comp.get("throughput", []) if cl else [])
        best = max((r for r in rows_all if r["batch"] > 1), key=lambda r: r["moves_per_s"], default=None)
        if best:
            out.append(f"| batched throughput ≥ 50,000 moves/s | {best['moves_per_s']:,.0f} moves/s "
                       f"({best['processes']} process(es), batches of {best['batch']}, {_client_label(best)}"
                       f"{', compiled engine' if cl and best in comp.get('throughput', []) else ''}) "
                       f"| {_verdict(50000.0, best['moves_per_s'])} |")
    elif svc:
        out.append(f"| service | not measured: {svc.get('failed')} | gap |")
    st = results.get("stress")
    if st:
        t = st["totals"]
        bad = sum(t.get(k, 0) for k in ("nonfinite", "fall_through", "penetration", "exceptions", "refusal_changed",
                                         "nondeterministic"))
        out.append(f"| stress: ≥ 1,000,000 moves, zero NaN/inf, fall-throughs, penetrations, exceptions "
                   f"| {t['moves']:,} moves; {t['nonfinite']} / {t['fall_through']} / {t['penetration']} / {t['exceptions']} "
                   f"| {'clean in this run' if not bad else 'FAILURES'}{'' if t['moves'] >= 1_000_000 else ', fewer moves than asked'}"
                   f"{_findings_note()} |")
    return out + [""]


def _summary_issue10(results: dict[str, Any]) -> list[str]:
    """Issue 10's targets (the service against the engine, every core, memory), from this file's sections."""
    out = ["## Targets of issue 10: where each stands", "",
           "| target | measured | verdict |", "|---|---|---|"]
    svc = results.get("service") or {}
    issue = svc.get("issue10_columns")
    if issue:
        eng = issue["engine"]
        for row in issue["service"]:
            out.append(f"| batched throughput ≥ 0.8 of `World.move` in process, same movers and moves ({row['form']}) "
                       f"| {row['moves_per_s']:,.0f} vs {eng['moves_per_s']:,.0f} moves/s: {row['ratio_to_engine']:.2f} "
                       f"({row['cpu_ratio_to_engine']:.2f} in CPU per move: {row['service_cpu_us_per_move']:.1f} vs "
                       f"{eng['cpu_us_per_move']:.1f} µs) | {'met' if row['ratio_to_engine'] >= 0.8 else 'missed'} |")
    lat = svc.get("latency")
    if lat:
        r = lat["ratio_move_to_echo"]
        out.append(f"| one-move round trip ≤ 1.2x the bare Zenoh echo, interleaved | {lat['move']['median']:.0f} vs "
                   f"{lat['echo']['median']:.0f} µs: {r:.2f}x | {'met' if r <= 1.2 else 'missed'} |")
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


def _limits(results: dict[str, Any]) -> list[str]:
    """What stands between each measured figure and its target, from the numbers of this run."""
    out = ["## What limits each figure", ""]
    eng = results.get("engine")
    if eng:
        flat = next((r for r in eng["traces"] if r["name"] == "flat"), None)
        prof = next((p for p in eng.get("profiles", []) if p["workload"] == "flat"), None)
        compiled = eng.get("meta", {}).get("machine", {}).get("compiled_engine_modules") or []
        txt = "- Engine: "
        if flat:
            txt += (f"a flat-terrain move takes {flat['us']['median']:.0f} µs against ACE's 4.5 µs under Mono "
                    f"({flat['us']['median'] / 4.5:.0f}x). ")
        if prof:
            txt += (f"The profile of the flat workload counts {prof['python_calls_per_move']:,.0f} interpreted function "
                    "calls per move (compiled functions count as one call each); ")
        if prof and prof["top"]:
            t0 = prof["top"][0]
            txt += (f"the biggest single function (`{t0['function']}`) has {100 * t0['own_share']:.0f} % of the own "
                    "time, the rest is spread over the per-step geometry (vector and plane arithmetic that allocates "
                    "a new object per operation, the cell and sphere loops of the transition): no single hot spot "
                    "closes a gap of this size; compiling the per-step path, or restructuring it to allocate less, is "
                    "what the issue asks for. ")
        var = eng.get("variant") or {}
        vflat = next((r["us"]["median"] for r in var.get("traces", []) if r["name"] == "flat" and "us" in r), None)
        if var.get("kind") == "compiled" and vflat and flat:
            txt += (f"Compiled with mypyc (the project's setup.py, built by `--build-compiled`), the flat trace takes "
                    f"{vflat:.1f} µs ({vflat / 4.5:.1f}x ACE, {flat['us']['median'] / vflat:.1f}x faster than "
                    "interpreted) with the same answers (section 2: error 0 against the interpreted run). The "
                    "compiled build is not profiled here (cProfile does not see inside compiled functions).")
        elif var.get("kind") == "pure" and vflat and flat:
            txt += (f"This run's tree is compiled ({len(compiled)} modules); interpreted, the flat trace takes "
                    f"{vflat:.1f} µs ({vflat / flat['us']['median']:.1f}x slower).")
        else:
            txt += (f"Compiled modules in this run: {len(compiled)}." if compiled else
                    "This run measured the interpreted engine only.")
        out.append(txt)
    svc = results.get("service")
    if svc and "latency" in svc:
        lat = svc["latency"]
        eng_us = _nan((lat.get("service_engine_ms") or {}).get("p50")) * 1000.0
        over = lat["move"]["median"] - lat["echo"]["median"] - (eng_us if math.isfinite(eng_us) else 0.0)
        best = max((r for r in svc["throughput"] if r["batch"] > 1), key=lambda r: r["moves_per_s"], default=None)
        txt = (f"- Service round trip: {lat['move']['median']:.0f} µs = the bare echo ({lat['echo']['median']:.0f} µs) "
               f"+ the engine ({_f(eng_us, 0)} µs, the service's own median) + {over:.0f} µs of client library and "
               "service work (msgpack and the State on both sides, the reply; no State is published, nobody subscribes; the "
               "move runs in the query's callback when the engine is idle, with no hand-off to another thread). "
               f"Meeting 1.2x the echo leaves {0.2 * lat['echo']['median']:.0f} µs for all of it, the engine included.")
        hd = lat.get("handling_us") or {}
        hot, warm = hd.get("gap_0us"), hd.get("gap_400us")
        if hot and warm:
            txt += (f" Without the network the service handles one move in {hot['handler']['median']:.0f} µs back to "
                    f"back (engine {hot['engine']['median']:.0f} µs) but in {warm['handler']['median']:.0f} µs "
                    f"(engine {warm['engine']['median']:.0f} µs) when each move follows 0.4 ms of idling, as in a "
                    "round trip: on this shared machine code runs 2-3x slower after the CPU idled or ran other "
                    "processes, and the service runs far more code per request than the echo.")
        out.append(txt)
        if best and best.get("service_cpu_us_per_move"):
            cpu = best["service_cpu_us_per_move"]
            comp = svc.get("compiled") or {}
            cbest = max((r for r in comp.get("throughput", []) if r["batch"] > 1), key=lambda r: r["moves_per_s"],
                        default=None)
            ctxt = ""
            if cbest and cbest.get("service_cpu_us_per_move"):
                cc = cbest["service_cpu_us_per_move"]
                ceng = _nan((comp["latency"].get("service_engine_ms") or {}).get("p50")) * 1000.0
                ctxt = (f" With the compiled engine the service spends {cc:.0f} µs of CPU per move (the engine "
                        f"itself {_f(ceng, 0)} µs of it), a ceiling of ~{1e6 / cc:,.0f} moves/s; everything in the "
                        "service but the engine is now the larger part of a move's cost.")
            both = ""
            rows_all = list(svc["throughput"]) + list(comp.get("throughput", []))
            top = max((r for r in rows_all if r["batch"] > 1 and r.get("client_cpu_us_per_move")),
                      key=lambda r: r["moves_per_s"], default=None)
            if top:
                total = top["service_cpu_us_per_move"] + top["client_cpu_us_per_move"]
                cpus = (svc.get("meta", {}).get("machine", {}) or {}).get("cpus") or 2
                both = (f" In the fastest batched run ({top['moves_per_s']:,.0f} moves/s, {_client_label(top)}) a move "
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
        issue = svc.get("issue10_columns") or {}
        cols = next((r for r in issue.get("service", []) if r["form"] == "columns"), None)
        if cols and cols.get("engine_in_service_us") is not None:
            eng = issue["engine"]
            need = eng["cpu_us_per_move"] / 0.8
            out.append(
                f"- Issue 10's batched throughput: with the column form a move cost the service "
                f"{cols['service_cpu_us_per_move']:.1f} µs of CPU, of which {cols['engine_in_service_us']:.1f} µs in "
                f"the engine (its own stats) and {cols['service_beyond_engine_us']:.1f} µs in everything else "
                "(Zenoh's receive and reply, msgpack, the column checks, the rows' bookkeeping and the reply's "
                f"arrays). In a process of its own the same engine took {eng['cpu_us_per_move']:.1f} µs per move: "
                "inside the service it shares this machine's two cores with the two client processes and "
                "Zenoh's threads. 0.8 of the engine's rate asks the whole service for at most "
                f"{need:.1f} µs per move.")
    err = results.get("error")
    if err and err["settings"]:
        base = err["settings"][0]["name"]
        over = sorted(((t, d["max_err_ref"].get(base) or 0.0) for t, d in err["per_trace"].items()), key=lambda x: -x[1])
        big = [f"{t} ({_e(v)} m)" for t, v in over if v > 1e-4]
        e0 = err["settings"][0]["err_ref"]
        n0 = err["settings"][0]["moves"] or 1
        out.append(f"- Error: the most exact setting's per-move median error is {_e(e0['median'])} m; "
                   f"{e0.get('over_1e-4', 0):,} of {n0:,} moves ({100 * e0.get('over_1e-4', 0) / n0:.2f} %) are more "
                   f"than 1e-4 m off and {e0.get('over_1e-3', 0):,} more than 1e-3 m, against the 1 % a p99 of 1e-4 m "
                   f"allows. Traces whose largest error exceeds 1e-4 m: {', '.join(big) if big else 'none'}. "
                   + _known_text(err) + _over_text(err))
    if err is not None:
        out.append(_skips_text(err))
    return out + [""]


def _skips_text(err: dict[str, Any]) -> str:
    """What switching each skip off did: error against the most exact setting
    (must be 0) and run time against the reference row of the same run."""
    rows = {r["name"]: r for r in err["settings"]}
    base = err["settings"][0]
    parts = []
    for name, r in rows.items():
        if "+skip_" not in name or not name.endswith("=false"):
            continue
        skip = name.split("+", 1)[1].split("=", 1)[0]
        vs = r.get("err_base") or {}
        saved = 100.0 * (r["us_mean"] - base["us_mean"]) / r["us_mean"] if r.get("us_mean") else 0.0
        parts.append(f"`{skip}` off: {vs.get('nonzero', 0)} moves differ from the most exact setting (max "
                     f"{_e(vs.get('max', 0.0))} m, contact state {100 * r.get('contact_base_frac', 0.0):.2f} %); the "
                     f"skip saves {saved:.0f} % of the mean time per move")
    if not parts:
        return ("- Skips (issue 6, \"skip what a scene does not need\"): no skip is an EngineSettings field, so "
                "none is measured here.")
    return ("- Skips (issue 6, \"skip what a scene does not need\"), each switched off in its own row of section 2 "
            "(interpreted, one run; a few % is within the noise of the repeat row): " + "; ".join(parts) + ".")


def _over_text(err: dict[str, Any]) -> str:
    rows = sorted(((t, d.get("over_1e-4", 0), d["moves"]) for t, d in err["per_trace"].items() if d.get("over_1e-4")),
                  key=lambda x: -x[1])
    if not rows:
        return ""
    return (" The moves more than 1e-4 m off, by trace: "
            + ", ".join(f"{t} {n:,} of {m:,}" for t, n, m in rows[:10]) + ".")


def _known_text(err: dict[str, Any]) -> str:
    known = set(err.get("known_divergent") or [])
    worst = err.get("worst_cases") or []
    unknown = [cid for cid, _ in worst if cid not in known]
    wk = err["settings"][0].get("err_ref_without_known") or {}
    txt = (f"Every case with a move more than 1 mm off ({len(worst)}) is one of the known divergences of "
           "tests/test_trace_replay.py" if worst and not unknown else
           f"Cases more than 1 mm off that are not listed as known divergences: {', '.join(unknown) or 'none'}")
    if wk.get("moves"):
        txt += (f"; without those {len(known)} cases ({wk['moves']:,} moves left) the p99 is {_e(wk.get('p99'))} m "
                f"and the largest error {_e(wk.get('max'))} m")
    return txt + "."


def _engine_tables(eng: dict[str, Any]) -> list[str]:
    var = eng.get("variant") or eng.get("pure") or {}
    kind = var.get("kind", "pure") if var else None
    has = bool(var) and not var.get("failed")
    vw = {r["name"]: r for r in var.get("workloads", []) if "us" in r} if has else {}
    vt = {r["name"]: r for r in var.get("traces", []) if "us" in r} if has else {}
    label = "pure Python" if kind == "pure" else "compiled"

    def speedup(this: float, other: float | None) -> str:
        if not other:
            return ""
        return _ratio(other / this if kind == "pure" else this / other)

    head = "| workload | what it does | median µs | p99 µs | moves/s | target µs | median / target |"
    rule = "|---|---|---:|---:|---:|---:|---:|"
    if has:
        head += f" {label} median µs | compiled speed-up |"
        rule += "---:|---:|"
    out = [head, rule]
    for r in eng["workloads"]:
        if "us" not in r:
            out.append(f"| {r['name']} | {r['description']} | not measured: {r['unavailable']} | | | | |" + (" | |" if has else ""))
            continue
        u = r["us"]
        line = (f"| {r['name']} | {r['description']} | {u['median']:.1f} | {u['p99']:.1f} | {r['moves_per_s']:,.0f} "
                f"| {_f(r.get('target_us'), 0)} | {u['median'] / r['target_us']:.1f}x |")
        if has:
            o = vw.get(r["name"], {}).get("us", {}).get("median")
            line += f" {_f(o)} | {speedup(u['median'], o)} |"
        out.append(line)
    out += ["", ("The reference traces replayed move by move (ACE_COMPAT, placements skipped) against ACE's own time "
            "per move on the same traces (issue 6 anchors: ACE compiled with mcs, run under Mono, on this machine class):"), ""]
    head = "| trace scene | moves | median µs | p99 µs | moves/s | ACE µs | acphys / ACE |"
    rule = "|---|---:|---:|---:|---:|---:|---:|"
    if has:
        head += f" {label} median µs | {label} / ACE | compiled speed-up |"
        rule += "---:|---:|---:|"
    out += [head, rule]
    for r in eng["traces"]:
        u = r["us"]
        line = (f"| {r['name']} | {u['n']:,} | {u['median']:.1f} | {u['p99']:.1f} | {r['moves_per_s']:,.0f} "
                f"| {_f(r.get('anchor_us'))} | {_ratio(r.get('ratio_to_ace'))} |")
        if has:
            o = vt.get(r["name"], {}).get("us", {}).get("median")
            line += (f" {_f(o)} | {_ratio(o / r['anchor_us'] if o and r.get('anchor_us') else None)} "
                     f"| {speedup(u['median'], o)} |")
        out.append(line)
    if var.get("failed"):
        out += ["", f"The {label} run failed: {var['failed']}"]
    elif has:
        out += ["", (f"The {label} columns: the same workloads in a child process that imports a "
                     + ("copy of the engine's .py sources only" if kind == "pure" else
                        "copy of the engine compiled with the project's setup.py (mypyc)")
                     + " (`benchmarks/pure.py`), in the same run, with fewer moves (2,000 per workload, at most "
                     "3,000 per trace).")]
    else:
        out += ["", ("The working tree's engine only (no other build measured beside it; "
                     "`--build-compiled` adds a compiled copy).")]
    return out


def _crowd_table(eng: dict[str, Any]) -> list[str]:
    """Crowds of live movers with the broad phase (skip_far_movers) on and off (issue 12)."""
    rows = eng.get("crowds") or []
    if not rows:
        return []
    out = ["", ("Crowds of live movers (`benchmarks/crowds.py`; RETAIL): creatures walking 0.2 m and back in turn, "
                "timed with the broad phase (`skip_far_movers`, on by default) on and off in alternating blocks:"), "",
           "| crowd | what it is | on: median µs | on: p99 µs | off: median µs | off: p99 µs | off / on |",
           "|---|---|---:|---:|---:|---:|---:|"]
    for r in rows:
        on, off = r["on_us"], r["off_us"]
        out.append(f"| {r['name']} | {r['description']} | {on['median']:.1f} | {on['p99']:.1f} | {off['median']:.1f} "
                   f"| {off['p99']:.1f} | {_ratio(r['off_over_on'])} |")
    return out


def _engine(eng: dict[str, Any], plot: str | None) -> list[str]:
    out = ["## 1. Engine, in process", "", _meta(eng), "",
           ("Only the engine call is timed (`World.move` / `World.step`: one transition plus SetPositionInternal, "
           "as ACE's anchor figures); targets are built and movers reset outside the timer. Scenes are built by "
           "`benchmarks/scenes.py` (synthetic terrain and sphere objects) or are the shared reference scenes. "
           f"{eng['moves_per_workload']} timed moves per workload after a warm-up, RETAIL settings."), "",
           *_engine_tables(eng), *_crowd_table(eng)]
    if plot:
        out += ["", f"![engine µs per move]({plot})"]
    for prof in eng.get("profiles", []):
        out += ["", (f"Where the time goes, `{prof['workload']}` ({prof['moves']} moves under cProfile, which slows "
                f"everything down but keeps the proportions): {prof['python_calls_per_move']:,.0f} Python function "
                "calls per move. Own time of the top functions:"), "",
                "| function | calls per move | own time | with callees |", "|---|---:|---:|---:|"]
        for r in prof["top"]:
            out.append(f"| `{r['function']}` | {r['calls_per_move']:.1f} | {100 * r['own_share']:.1f} % "
                       f"| {100 * r['cumulative_share']:.1f} % |")
    return out + [""]


def _retail_corrections(rc: dict[str, Any] | None) -> list[str]:
    """The table of benchmarks/bench_retail.py: RETAIL's corrections off the traces."""
    if not rc or not rc.get("rows"):
        return []
    out = ["", ("RETAIL's corrections of ACE, on a workload that exercises them (`benchmarks/bench_retail.py`: a "
           f"player running through uneven frames of 1/60 s to 0.5 s, a sled on a walkable slope; {rc['calls']} calls "
           "each). Moved: distance from where the mover is under ACE_COMPAT after the same calls, at the end and at "
           "most."), "",
           "| workload | scene | setting | µs/call mean | moved at the end m | moved at most m |",
           "|---|---|---|---:|---:|---:|"]
    for r in rc["rows"]:
        out.append(f"| {r['workload']} | {r['scene']} | `{r['name']}` | {_f(r['us_mean'])} | {_e(r['moved_final_m'])} "
                   f"| {_e(r['moved_max_m'])} |")
    return out


def _error(err: dict[str, Any], plot: str | None) -> list[str]:
    lim = err.get("cases_per_trace")
    out = ["## 2. Run time against error", "", _meta(err), "",
           (f"Workload: every reference trace of `../shared/oracle/traces/` "
           f"({'all cases' if not lim else f'the first {lim} case(s) of each'}), each case replayed under every setting "
           "in turn. Error against the reference: distance of the final position from the reference's, per move "
           "(global metres); contact differs: `contact` or `on_walkable` disagree. Error against the most exact "
           f"setting: the same against `{err['reference_setting']}`'s own results. Run time: the engine call per move "
           "(transitions and placements), mean and median."), "",
           ("Settings: `SETTINGS` in `benchmarks/bench_error.py` (one line each); presets in "
           "`engine/transition/settings.py` and EngineSettings fields added later are picked up on their own."), "",
           "| setting | what it is | moves | µs/move mean | µs median | error median m | p99 m | max m | contact differs | vs most exact: p99 m | max m | contact differs | Pareto |",
           "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    front = set(err.get("pareto", []))
    for r in err["settings"]:
        e, b = r["err_ref"], r["err_base"]
        out.append(f"| `{r['name']}` | {r['description']} | {r['moves']:,} | {_f(r['us_mean'])} | {_f(r['us_median'])} "
                   f"| {_e(e['median'])} | {_e(e['p99'])} | {_e(e['max'])} | {_pct(r['contact_ref_frac'])} "
                   f"| {_e(b['p99'])} | {_e(b['max'])} | {_pct(r['contact_base_frac'])} | {'yes' if r['name'] in front else ''} |")
    rep = [r for r in err["settings"] if r["name"].endswith("(repeat)")]
    if rep and err["settings"]:
        a, b = _nan(err["settings"][0]["us_mean"]), _nan(rep[0]["us_mean"])
        out += ["", (f"Noise: `{rep[0]['name']}` runs the first row's settings again; its mean run time differs from the "
                f"first row's by {100.0 * abs(b - a) / a:.1f} %. Run-time differences between rows smaller than that "
                "are machine noise (the EngineSettings rows differ only on the rare moves that hit the step cap or an outdoor camera).")]
    worst = err.get("worst_cases") or []
    if worst:
        known = set(err.get("known_divergent") or [])
        n_known = sum(1 for cid, _ in worst if cid in known)
        out += ["", (f"Cases where `{err['reference_setting']}` ends some move more than 1 mm from the reference "
                f"({len(worst)}; {n_known} of them listed as known divergences in tests/test_trace_replay.py):"), ""]
        out.append(", ".join(f"{cid} {_e(v)} m{' (known)' if cid in known else ''}" for cid, v in worst[:25])
                   + (", ..." if len(worst) > 25 else "") + ".")
    out += _retail_corrections(err.get("retail_corrections"))
    pend = [r for r in err.get("pending", []) if r["moves"]]
    if pend:
        out += ["", ("Traces still being ported when this harness was written (dungeon, objects, several movers), "
                "reported apart:"), "",
                "| setting | moves | µs/move mean | error median m | p99 m | max m | contact differs |",
                "|---|---:|---:|---:|---:|---:|---:|"]
        for r in pend:
            e = r["err_ref"]
            out.append(f"| `{r['name']}` | {r['moves']:,} | {_f(r['us_mean'])} | {_e(e['median'])} | {_e(e['p99'])} "
                       f"| {_e(e['max'])} | {_pct(r['contact_ref_frac'])} |")
    if err.get("skipped"):
        out += ["", "Not run (exceptions while loading or replaying):", ""]
        out += [f"- {k}: {v}" for k, v in list(err["skipped"].items())[:20]]
    has_var = any(r["name"].endswith((", pure", ", compiled")) for r in err["settings"])
    out += ["", ("Compiled against pure Python: " + (
        "the `..., pure` or `..., compiled` row runs the first row's settings on the other build of the engine in a "
        "child process (`benchmarks/pure.py`); its error against the most exact setting is the difference between "
        "compiled and interpreted answers, which must be 0." if has_var else
        "only the working tree's build was measured; `--build-compiled` (or a compiled tree) adds a row for the "
        "other build.")
        + " Not a setting yet: float32 against float64 arithmetic and the step subdivision size; the engine "
        "offers neither as a switch (see `engine/transition/settings.py`). Each becomes one line of `SETTINGS` "
        "when it does. The skips are settings: each `+skip_...=false` row switches one off, and must show "
        "error 0 against the most exact setting.")]
    if plot:
        out += ["", f"![run time against error]({plot})"]
    return out + [""]


def _client_label(r: dict[str, Any]) -> str:
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
                   f"| {r['moves_per_s']:,.0f} | {_f(r['service_cpu_us_per_move'], 0)} "
                   f"| {_f(r.get('client_cpu_us_per_move'), 0)} | {r['errors']} |")
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


def workers_table(rows: list[dict[str, Any]]) -> list[str]:
    """The `--workers` rows: throughput and each side's CPU use."""
    out = ["| engine processes | client processes | moves/s | service CPU, cores | client CPU, cores "
           "| service CPU µs per move | errors |", "|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        out.append(f"| {r['workers']} | {r['processes']} | {r['moves_per_s']:,.0f} | {r['service_cores']:.2f} "
                   f"| {r['client_cores']:.2f} | {_f(r['service_cpu_us_per_move'], 0)} | {r['errors']} |")
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
    return out


def _run_batch_note(eng: dict[str, Any]) -> str:
    """The engine's own batch entry point on the same moves, where the run measured it."""
    rb = eng.get("run_batch")
    if not rb:
        return ""
    return (f"; the engine's batch entry point (`engine.world.batch.run_batch`, batches of 100 as the clients send "
            f"them) {rb['moves_per_s']:,.0f} moves/s, {rb['cpu_us_per_move']:.1f} µs of CPU per move")


def _issue10(data: dict[str, Any] | None, label: str) -> list[str]:
    """Issue 10's workload through the map and the column batch, beside World.move in process."""
    if not data or "engine" not in data:
        return []
    eng = data["engine"]
    rounds = data.get("rounds", 1)
    how = (f"in {rounds} rounds of {data.get('seconds_each', 0):.0f} s each (World.move, then each form), "
           "medians over the rounds" if rounds > 1 else "in one round")
    out = ["", (f"Issue 10's workload ({label}): {data['movers']} player movers one every {data['spacing_m']:.0f} m on "
                f"the demo world walking ±{data['step_m']} m, two client processes each moving its half in batches of "
                "100 (every mover out and back), by map batch (`Client.move_many_maps`) and by column batch "
                "(`Client.move_batch`, docs/protocol.md, Column batches); beside it `World.move` on the same movers in "
                f"a process of its own, {how}: {eng['moves_per_s']:,.0f} moves/s, "
                f"{eng['cpu_us_per_move']:.1f} µs of CPU per move{_run_batch_note(eng)}. \"The engine inside the "
                "service\" is the service's own mean engine time per move (Stats `engine_ms`) while the clients run: "
                "the same engine code, slowed by the clients and Zenoh sharing this machine's two cores; the column "
                "after it is the rest of the service's CPU per move (decoding, checks, stats, encoding, Zenoh)."), "",
           "| batch form | moves/s | service CPU µs per move | the engine inside the service, µs per move | "
           "service CPU beyond its engine, µs per move | client CPU µs per move | moves/s / engine's | "
           "engine's CPU per move / service's | errors |", "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in data["service"]:
        inside, beyond = r.get("engine_in_service_us"), r.get("service_beyond_engine_us")
        out.append(f"| {r['form']} | {r['moves_per_s']:,.0f} | {r['service_cpu_us_per_move']:.1f} | "
                   f"{'-' if inside is None else f'{inside:.1f}'} | {'-' if beyond is None else f'{beyond:.1f}'} | "
                   f"{r['client_cpu_us_per_move']:.1f} | {r['ratio_to_engine']:.2f} | {r['cpu_ratio_to_engine']:.2f} | "
                   f"{r['errors']} |")
    per_round = [f"{r['form']} " + ", ".join(f"{x['ratio_to_engine']:.2f}" for x in r["rounds"])
                 for r in data["service"] if len(r.get("rounds") or []) > 1]
    if per_round:
        out += ["", "Each round's moves/s ratio: " + "; ".join(per_round) + "."]
    return out


def _service(svc: dict[str, Any], plot: str | None) -> list[str]:
    out = ["## 3. Service over loopback", "", _meta(svc), ""]
    if "latency" not in svc:
        return out + [f"Not measured: {svc.get('failed')}", ""]
    lat = svc["latency"]
    svc_compiled = svc.get("meta", {}).get("machine", {}).get("compiled_engine_modules")
    out += [f"First the service on the working tree's engine ({'compiled' if svc_compiled else 'interpreted'}).", ""]
    out += [("`python -m service` on a flat 3x3-landblock scene, `clients.Client` in this process; the floor is a bare "
            "Zenoh queryable in its own process answering with the request's bytes "
            f"({lat['probe_bytes']} bytes, the size of a one-move request), queried the same way in the same run, "
            "interleaved block by block with the service round trips. Peer mode, TCP on 127.0.0.1, multicast scouting off."), "",
            "| round trip | n | median µs | p99 µs | median µs per move |", "|---|---:|---:|---:|---:|"]
    for k, label, per in (("echo", "bare Zenoh echo", 1),
                          ("health", "health (a bare get the service answers with no engine)", 1),
                          ("raw_move", "one move as a bare get (no client library)", 1), ("move", "one move", 1),
                          ("batch10", "batch of 10 moves", 10), ("batch100", "batch of 100 moves", 100)):
        if k not in lat:  # results saved before the row was measured
            continue
        s = lat[k]
        out.append(f"| {label} | {s['n']} | {s['median']:.0f} | {s['p99']:.0f} | {s['median'] / per:.0f} |")
    out += _handling(lat)
    eng_ms = lat.get("service_engine_ms") or {}
    out += ["", (f"One move / echo: **{lat['ratio_move_to_echo']:.2f}x** at the median "
            f"({lat['ratio_move_to_echo_p99']:.2f}x at p99). Inside the service the engine took "
            f"{_f(_nan(eng_ms.get('p50')) * 1000, 0)} µs per move at the median (its own stats)."), "",
            _THROUGHPUT_TEXT, "", *_throughput_table(svc["throughput"])]
    out += _issue10(svc.get("issue10_columns"), "the working tree's engine")
    if svc.get("workers"):
        out += ["", WORKERS_TEXT, "", *workers_table(svc["workers"])]
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
        ce = _nan((cl.get("service_engine_ms") or {}).get("p50")) * 1000.0
        out += ["", f"One move / echo: **{cl['ratio_move_to_echo']:.2f}x**; engine {_f(ce, 0)} µs per move inside the service.", "",
                *_throughput_table(comp["throughput"])]
        out += _issue10(comp.get("issue10_columns"), "compiled engine")
    elif comp:
        out += ["", f"The compiled-engine service run failed: {comp.get('failed')}"]
    if plot:
        out += ["", f"![service]({plot})"]
    return out + [""]


def _memory(mem: dict[str, Any]) -> list[str]:
    out = ["## Memory: the service under reconnecting bulk clients", "", _meta(mem), "",
           (f"Client sessions two at a time, each its own process with Zenoh's default configuration (shared memory "
            f"on), each registering {mem['movers_per_session']} movers, sending batches of {mem['batch']} moves "
            "(about 5 KB, over Zenoh's 3 KiB shared-memory threshold), removing its movers and leaving "
            "(benchmarks/bench_memory.py). RSS of the service process from /proc, once a second. The first row is the "
            "service as shipped; the second gives the same service a config file that turns Zenoh's shared-memory "
            "transport back on, as it ran before (service/zconfig.py says why it is off)."), "",
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


def _stress(st: dict[str, Any]) -> list[str]:
    t = st["totals"]
    out = ["## 4. Numerical-stability stress", "", _meta(st), "",
           (f"{t['moves']:,} moves by {t['movers']:,} movers (asked for {st['requested_moves']:,} within "
           f"{st['seconds_budget']:.0f} s, {st['jobs']} worker processes, seed {st['seed']}); scenarios and checks "
           "are described in `benchmarks/stress.py`: random walks mixing ordinary steps, zero-length, sub-millimetre, "
           "5-60 m and 100-400 m moves, axis-aligned and grazing moves along cell edges and walls, vertical drops and "
           "jumps, physics steps; the player, tiny (1 mm-5 cm) and huge (3-15 m) spheres; starts exactly on the "
           "ground, on cell corners and landblock edges, at reference starts, exactly touching a wall of the room or a sphere object; "
           "scenes with the far corner of the world (0xFE..0xFF), degenerate polygons (zero-area, repeated vertex); "
           "and object-kinds (`benchmarks/object_kinds.py`): every combination of IsViewer, PathClipped, PerfectClip, "
           "EdgeSlide, FreeRotate and IsPlayer, spheres of 1 mm-15 m, starts on, under and high above the ground, on "
           "cell corners and landblock edges, on open water and indoors, under RETAIL and ACE_COMPAT, each case's "
           "refused moves checked to leave the mover as it was and every fourth case run twice to check it answers "
           "the same."), "",
           "| scenario | moves | NaN/inf | fall-throughs (> 1 cm) | wall/object penetrations (> 1 cm) | exceptions "
           "| refusals that changed the mover | not deterministic | doorway-corner overlaps | input errors |",
           "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in st["scenarios"]:
        out.append(f"| {r['scenario']} | {r['moves']:,} | {r['nonfinite']} | {r['fall_through']} | {r['penetration']} "
                   f"| {r['exceptions']} | {r.get('refusal_changed', 0)} | {r.get('nondeterministic', 0)} "
                   f"| {r.get('corner_overlap', 0)} | {r['rejected']} |")
    out.append(f"| **all** | **{t['moves']:,}** | **{t['nonfinite']}** | **{t['fall_through']}** | **{t['penetration']}** "
               f"| **{t['exceptions']}** | **{t.get('refusal_changed', 0)}** | **{t.get('nondeterministic', 0)}** "
               f"| {t.get('corner_overlap', 0)} | {t['rejected']} |")
    fails = [(r["scenario"], f) for r in st["scenarios"] for f in r["failures"]]
    if fails:
        out += ["", ("Failures (each with its reproducer in `benchmarks/out/stress_failures.json`; "
                "`benchmarks.stress.replay(entry)` rebuilds the scene and replays the mover's moves):"), ""]
        for sc, f in fails[:10]:
            detail = f.get("error") or (f"{f['below_m']:.4f} m below" if "below_m" in f else
                                         f"{f['depth_m']:.4f} m deep" if "depth_m" in f else "")
            where = f.get("case") or f.get("start")
            last = (f"last move {f['moves'][-1][0]} {tuple(round(c, 3) for c in f['moves'][-1][1])}"
                    if f.get("moves") else "its moves in the case")
            out.append(f"- {sc}: {f['kind']} of a {f.get('mover', '')} mover (start {where}), {last}: {detail}; ended at "
                       f"{f.get('result', '?')}")
        out += ["", ("Each kind of failure found is a regression test in tests/test_stress_regressions.py (a strict "
                "expected failure while the engine gets it wrong).")]
    from .stress import FINDINGS

    if FINDINGS:
        out += ["", ("Found by earlier stress runs (other seeds, or before a check was added), each now a regression "
                "test in tests/test_stress_regressions.py; a run that does not meet them again has not fixed them:"), ""]
        out += [f"- {what} (`{test}`)" for what, test in FINDINGS]
    out += ["", ("\"Input errors\" are the engine's documented refusals (EngineError subclasses, e.g. a target in a "
            "landblock that is not loaded, or beyond the limits of docs/protocol.md); they are not failures. "
            "\"Doorway-corner overlaps\" are walls reached into by at most 5 cm after a long move that reported a "
            "collision: the client's own behaviour (docs/divergences.md), not penetrations.")]
    return out + [""]


HEADER = """# Performance

Generated by `python3 -m benchmarks` (benchmarks/run.py); do not edit by hand, re-run it. Each section
says the exact command, the commit and the machine it was measured on. The machine is a shared 2-core
VM: all figures are medians and 99th percentiles of one run, and the ratios are between figures
measured in the same run. Nothing here is asserted by the test suite.

Re-run:

    pip install matplotlib          # for the plots (optional)
    python3 -m benchmarks --build-compiled   # everything, with a mypyc-compiled copy beside an
                                             # interpreted tree (about ten minutes here), or:
    python3 -m benchmarks           # everything, the working tree's build only
    python3 -m benchmarks --quick   # a few minutes, small counts
    python3 -m benchmarks --only engine,error --error-cases 5
    python3 -m benchmarks --only stress --stress-moves 1000000 --stress-seconds 3600

Raw results: `docs/performance.json` (each section's latest run); plots: `benchmarks/plots/`.
"""


def write(results: dict[str, Any]) -> None:
    lines = [HEADER, *_summary(results), *_summary_issue10(results), *_limits(results)]
    if "engine" in results:
        lines += _engine(results["engine"], plot_engine(results["engine"]))
    if "error" in results:
        lines += _error(results["error"], plot_error(results["error"]))
    if "service" in results:
        lines += _service(results["service"], plot_service(results["service"]))
    if "memory" in results:
        lines += _memory(results["memory"])
    if "stress" in results:
        lines += _stress(results["stress"])
    if "queries" in results:
        from .bench_queries import section

        lines += section(results["queries"], _meta(results["queries"]))
    extra = results.get("notes")
    if extra:
        lines += ["## Notes", "", extra, ""]
    common.DOC.write_text("\n".join(lines).rstrip() + "\n", encoding="utf-8")
