"""docs/performance.md and its plots, from docs/performance.json (the stored results of every section)."""

from __future__ import annotations

from typing import Any

from . import common
from .report_format import as_float, meta_line, num, pct, pyplot, ratio, save_plot, sci, verdict_of
from .report_service import (
    client_label,
    memory_section,
    plot_service,
    service_limits,
    service_section,
    service_targets,
)


def _findings_note() -> str:
    from .stress import FINDINGS

    open_ = [w for w, t in FINDINGS if "xfail" in t]
    return f"; earlier runs found {len(open_)} open engine issue(s), see section 4" if open_ else ""


def plot_engine(eng: dict[str, Any]) -> str | None:
    plt = pyplot()
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
    a1.set_title("synthetic workloads (RETAIL); red: engine target")
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
    return save_plot(plt, fig, "engine.png")


def plot_error(err: dict[str, Any]) -> str | None:
    plt = pyplot()
    if plt is None:
        return None
    rows = [r for r in err["settings"] if r["moves"]]
    front = set(err.get("pareto", []))
    floor = 1e-7
    fig, ax = plt.subplots(figsize=(8, 5))
    for r in rows:
        x, y = as_float(r["us_mean"]), max(floor, as_float(r["err_ref"]["p99"]))
        on = r["name"] in front
        ax.scatter([x], [y], s=70 if on else 40, color="tab:red" if on else "tab:blue", zorder=3)
        ax.annotate(r["name"], (x, y), textcoords="offset points", xytext=(6, 4), fontsize=8)
    pts = sorted((as_float(r["us_mean"]), max(floor, as_float(r["err_ref"]["p99"]))) for r in rows if r["name"] in front)
    if len(pts) > 1:
        ax.step([p[0] for p in pts], [p[1] for p in pts], where="post", color="tab:red", alpha=0.5, label="Pareto front")
    ax.axhline(1e-4, color="green", linestyle="dashed", label="target: most exact p99 ≤ 1e-4 m")
    ax.axhline(1e-3, color="orange", linestyle="dashed", label="target: fastest on front ≤ 1e-3 m")
    ax.set_yscale("log")
    ax.set_xlabel("run time, µs per move (mean over the reference traces)")
    ax.set_ylabel("p99 final-position error against the reference (m)")
    ax.set_title("run time against error, one point per engine setting")
    ax.legend(fontsize=8)
    return save_plot(plt, fig, "error_pareto.png")


def _engine_targets(results: dict[str, Any]) -> list[str]:
    out = ["## Engine targets: where each stands", "",
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
            verdict = verdict_of(med, lim)
            if other:
                txt += f"; {other:.1f} µs {vkind}" + (f" ({other / anchor:.1f}x ACE)" if anchor else "")
                best = min(med, other)
                verdict = verdict_of(best, lim) + (" (best build)" if tree else "")
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
        p99 = as_float(ref["err_ref"]["p99"])
        wk = ref.get("err_ref_without_known") or {}
        extra = f" ({sci(wk.get('p99'))} m without the known divergent cases)" if wk.get("moves") else ""
        out.append(f"| most exact setting (`{ref['name']}`): p99 error ≤ 1e-4 m | {sci(p99)} m{extra} "
                   f"| {'met' if p99 <= 1e-4 else f'missed ({p99 / 1e-4:.1f}x)'} |")
        front = [r for r in err["settings"] if r["name"] in err.get("pareto", [])]
        if front:
            fastest = min(front, key=lambda r: as_float(r["us_mean"]))
            fp = as_float(fastest["err_ref"]["p99"])
            out.append(f"| fastest setting on the Pareto front (`{fastest['name']}`): p99 ≤ 1e-3 m | {sci(fp)} m "
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
                       f"({best['processes']} process(es), batches of {best['batch']}, {client_label(best)}"
                       f"{', compiled engine' if cl and best in comp.get('throughput', []) else ''}) "
                       f"| {verdict_of(50000.0, best['moves_per_s'])} |")
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
            txt += (f"a move of the flat trace takes {flat['us']['median']:.1f} µs against ACE's 4.5 µs under Mono "
                    f"({flat['us']['median'] / 4.5:.2f}x). ")
        if prof:
            txt += (f"The profile of the flat workload counts {prof['python_calls_per_move']:,.0f} interpreted function "
                    "calls per move (compiled functions count as one call each); ")
        if prof and prof["top"]:
            t0 = prof["top"][0]
            txt += (f"the biggest single function (`{t0['function']}`) has {100 * t0['own_share']:.0f} % of the own "
                    "time (cProfile sees a compiled call as one function; the rest is the interpreted harness and "
                    "the World's entry points). ")
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
    out += service_limits(results)
    err = results.get("error")
    if err and err["settings"]:
        base = err["settings"][0]["name"]
        over = sorted(((t, d["max_err_ref"].get(base) or 0.0) for t, d in err["per_trace"].items()), key=lambda x: -x[1])
        big = [f"{t} ({sci(v)} m)" for t, v in over if v > 1e-4]
        e0 = err["settings"][0]["err_ref"]
        n0 = err["settings"][0]["moves"] or 1
        out.append(f"- Error: the most exact setting's per-move median error is {sci(e0['median'])} m; "
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
                     f"{sci(vs.get('max', 0.0))} m, contact state {100 * r.get('contact_base_frac', 0.0):.2f} %); the "
                     f"skip saves {saved:.0f} % of the mean time per move")
    if not parts:
        return ("- Skips (\"skip what a scene does not need\"): no skip is an EngineSettings field, so "
                "none is measured here.")
    return ("- Skips (\"skip what a scene does not need\"), each switched off in its own row of section 2 "
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
        txt += (f"; without those {len(known)} cases ({wk['moves']:,} moves left) the p99 is {sci(wk.get('p99'))} m "
                f"and the largest error {sci(wk.get('max'))} m")
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
        return ratio(other / this if kind == "pure" else this / other)

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
                f"| {num(r.get('target_us'), 0)} | {u['median'] / r['target_us']:.1f}x |")
        if has:
            o = vw.get(r["name"], {}).get("us", {}).get("median")
            line += f" {num(o)} | {speedup(u['median'], o)} |"
        out.append(line)
    rounds = max((len(r.get("round_medians_us") or []) for r in eng["traces"]), default=0)
    how = (f" Each trace is replayed {rounds} times, the traces taking turns; its row is the round with the lowest "
           "median, every round's median listed after the table (this machine has a slow mode lasting seconds)."
           if rounds > 1 else "")
    out += ["", ("The reference traces replayed move by move (ACE_COMPAT, placements skipped) against ACE's own time "
            "per move on the same traces (the anchors: ACE compiled with mcs, run under Mono, on this machine class)."
            + how), ""]
    head = "| trace scene | moves | median µs | p99 µs | moves/s | ACE µs | acphys / ACE |"
    rule = "|---|---:|---:|---:|---:|---:|---:|"
    if has:
        head += f" {label} median µs | {label} / ACE | compiled speed-up |"
        rule += "---:|---:|---:|"
    out += [head, rule]
    for r in eng["traces"]:
        u = r["us"]
        line = (f"| {r['name']} | {u['n']:,} | {u['median']:.1f} | {u['p99']:.1f} | {r['moves_per_s']:,.0f} "
                f"| {num(r.get('anchor_us'))} | {ratio(r.get('ratio_to_ace'))} |")
        if has:
            o = vt.get(r["name"], {}).get("us", {}).get("median")
            line += (f" {num(o)} | {ratio(o / r['anchor_us'] if o and r.get('anchor_us') else None)} "
                     f"| {speedup(u['median'], o)} |")
        out.append(line)
    if rounds > 1:
        out += ["", "Each round's median, µs per move: " + "; ".join(
            f"{r['name']} " + ", ".join(f"{m:.1f}" for m in r.get("round_medians_us") or []) for r in eng["traces"]) + "."]
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
    """Crowds of live movers with the broad phase (skip_far_movers) on and off."""
    rows = eng.get("crowds") or []
    if not rows:
        return []
    # the crowd rows may be measured apart from the rest of the section (bench_engine.run_crowds alone)
    meta = [meta_line({"meta": eng["crowds_meta"]}), ""] if eng.get("crowds_meta") else []
    smallest = rows[0]["on_us"]["median"]
    out = ["", *meta, ("Crowds of live movers (`benchmarks/crowds.py`; RETAIL): creatures walking 0.2 m and back in "
                       "turn, timed with the broad phase (`skip_far_movers`, on by default) on and off in alternating "
                       f"blocks; the last column is the median with the broad phase on over {rows[0]['name']}'s:"), "",
           "| crowd | what it is | on: median µs | on: p99 µs | off: median µs | off: p99 µs | off / on "
           f"| on / {rows[0]['name']} on |",
           "|---|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        on, off = r["on_us"], r["off_us"]
        out.append(f"| {r['name']} | {r['description']} | {on['median']:.1f} | {on['p99']:.1f} | {off['median']:.1f} "
                   f"| {off['p99']:.1f} | {ratio(r['off_over_on'])} | {ratio(on['median'] / smallest)} |")
    return out


def _engine(eng: dict[str, Any], plot: str | None) -> list[str]:
    out = ["## 1. Engine, in process", "", meta_line(eng), "",
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
        out.append(f"| {r['workload']} | {r['scene']} | `{r['name']}` | {num(r['us_mean'])} | {sci(r['moved_final_m'])} "
                   f"| {sci(r['moved_max_m'])} |")
    return out


def _error(err: dict[str, Any], plot: str | None) -> list[str]:
    lim = err.get("cases_per_trace")
    out = ["## 2. Run time against error", "", meta_line(err), "",
           (f"Workload: every reference trace of `../shared/oracle/traces/` "
           f"({'all cases' if not lim else f'the first {lim} case(s) of each'}), each case replayed under every setting "
           "in turn. Error against the reference: distance of the final position from the reference's, per move "
           "(global metres); contact differs: `contact` or `on_walkable` disagree. Error against the most exact "
           f"setting: the same against `{err['reference_setting']}`'s own results. Run time: the engine call per move "
           "(transitions and placements), mean and median."), "",
           ("Settings: `SETTINGS` in `benchmarks/bench_error.py` (one line each); presets in "
           "`engine/settings.py` and EngineSettings fields added later are picked up on their own."), "",
           "| setting | what it is | moves | µs/move mean | µs median | error median m | p99 m | max m | contact differs | vs most exact: p99 m | max m | contact differs | Pareto |",
           "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"]
    front = set(err.get("pareto", []))
    for r in err["settings"]:
        e, b = r["err_ref"], r["err_base"]
        out.append(f"| `{r['name']}` | {r['description']} | {r['moves']:,} | {num(r['us_mean'])} | {num(r['us_median'])} "
                   f"| {sci(e['median'])} | {sci(e['p99'])} | {sci(e['max'])} | {pct(r['contact_ref_frac'])} "
                   f"| {sci(b['p99'])} | {sci(b['max'])} | {pct(r['contact_base_frac'])} | {'yes' if r['name'] in front else ''} |")
    rep = [r for r in err["settings"] if r["name"].endswith("(repeat)")]
    if rep and err["settings"]:
        a, b = as_float(err["settings"][0]["us_mean"]), as_float(rep[0]["us_mean"])
        out += ["", (f"Noise: `{rep[0]['name']}` runs the first row's settings again; its mean run time differs from the "
                f"first row's by {100.0 * abs(b - a) / a:.1f} %. Run-time differences between rows smaller than that "
                "are machine noise (the EngineSettings rows differ only on the rare moves that hit the step cap or an outdoor camera).")]
    worst = err.get("worst_cases") or []
    if worst:
        known = set(err.get("known_divergent") or [])
        n_known = sum(1 for cid, _ in worst if cid in known)
        out += ["", (f"Cases where `{err['reference_setting']}` ends some move more than 1 mm from the reference "
                f"({len(worst)}; {n_known} of them listed as known divergences in tests/test_trace_replay.py):"), ""]
        out.append(", ".join(f"{cid} {sci(v)} m{' (known)' if cid in known else ''}" for cid, v in worst[:25])
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
            out.append(f"| `{r['name']}` | {r['moves']:,} | {num(r['us_mean'])} | {sci(e['median'])} | {sci(e['p99'])} "
                       f"| {sci(e['max'])} | {pct(r['contact_ref_frac'])} |")
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
        "offers neither as a switch (see `engine/settings.py`). Each becomes one line of `SETTINGS` "
        "when it does. The skips are settings: each `+skip_...=false` row switches one off, and must show "
        "error 0 against the most exact setting.")]
    if plot:
        out += ["", f"![run time against error]({plot})"]
    return out + [""]


def _stress(st: dict[str, Any]) -> list[str]:
    t = st["totals"]
    out = ["## 4. Numerical-stability stress", "", meta_line(st), "",
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
    python3 -m benchmarks --only instructions --against OLD_CHECKOUT   # callgrind counts: this checkout's
                                             # compiled engine against another's (needs valgrind)

Raw results: `docs/performance.json` (each section's latest run); plots: `benchmarks/plots/`.
"""


def write(results: dict[str, Any]) -> None:
    lines = [HEADER, *_engine_targets(results), *service_targets(results), *_limits(results)]
    if "engine" in results:
        lines += _engine(results["engine"], plot_engine(results["engine"]))
    if "error" in results:
        lines += _error(results["error"], plot_error(results["error"]))
    if "service" in results:
        lines += service_section(results["service"], plot_service(results["service"]))
    if "memory" in results:
        lines += memory_section(results["memory"])
    if "stress" in results:
        lines += _stress(results["stress"])
    if "queries" in results:
        from .bench_queries import section

        lines += section(results["queries"], meta_line(results["queries"]))
    if "instructions" in results:
        from .bench_instructions import section as instructions_section

        lines += instructions_section(results["instructions"], meta_line(results["instructions"]))
    if "navigation" in results:
        from .bench_navigation import section as navigation_section

        lines += navigation_section(results["navigation"], meta_line(results["navigation"]))
    if "durability" in results:
        from .bench_durability import section as durability_section

        lines += durability_section(results["durability"], meta_line(results["durability"]))
    if "wire_decoding" in results:
        from .bench_wire_decoding import section as wire_section

        lines += wire_section(results["wire_decoding"], meta_line(results["wire_decoding"]))
    if "many_movers" in results:
        from .bench_many_movers import section as many_movers_section

        lines += many_movers_section(results["many_movers"], meta_line(results["many_movers"]))
    extra = results.get("notes")
    if extra:
        lines += ["## Notes", "", extra, ""]
    common.DOC.write_text("\n".join(lines).rstrip() + "\n", encoding="utf-8")

