"""Run time against error: every engine setting on the same workload.

The workload is the shared reference traces (the ones the replay test runs,
plus, when the engine runs them, the ones still being ported). Each case is
replayed under every setting in turn (case by case, so machine noise hits
all settings alike). Per move:

- error against the reference: distance between the final position and the
  reference's (global metres, so cell and landblock changes count), and
  whether the contact state (contact, on_walkable) differs;
- error against the engine's own most exact setting (the first entry of
  SETTINGS): the same two measures against its results.

Run time: the engine call of each move (replay_move: a transition or a
placement); the expect-conversion of results is not timed.

Adding a setting is one line in SETTINGS. Presets defined in
engine/settings.py and new EngineSettings fields are picked up
by `all_settings()` without editing this file.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from typing import Any

import engine
from engine.constants import ACE_MAX_STEPS, RETAIL_MAX_STEPS
from engine import settings as settings_module

from . import common
from .common import log, pct

#: (name, what it is, settings). The first is the reference ("most exact") setting.
SETTINGS: list[tuple[str, str, engine.EngineSettings]] = [
    ("ace-compat", "ACE_COMPAT: ACE's departures from retail, step cap 1000", engine.ACE_COMPAT),
    ("ace-compat+retail-cap", "ACE_COMPAT with the retail step cap (30)", dataclasses.replace(engine.ACE_COMPAT, max_steps=RETAIL_MAX_STEPS)),
    ("retail", "RETAIL: the client's own behaviour, step cap 30", engine.RETAIL),
    ("retail+relaxed-cap", "RETAIL with the relaxed step cap (1000)", dataclasses.replace(engine.RETAIL, max_steps=ACE_MAX_STEPS)),
    ("ace-compat+double", "ACE_COMPAT computed and stored in double precision throughout",
     dataclasses.replace(engine.ACE_COMPAT, single_precision=False)),
    ("ace-compat+step-length=2", "ACE_COMPAT with sub-steps of up to two radii (the client: one)",
     dataclasses.replace(engine.ACE_COMPAT, step_length=2.0)),
    # RETAIL's corrections of ACE one at a time (docs/divergences.md); the traces step at 1/30 s and have
    # no sleds, so these must agree with the first row; benchmarks/bench_retail.py measures what they change
    ("ace-compat+quantum-ladder", "ACE_COMPAT with the client's physics step ladder (0.2 s quantum)",
     dataclasses.replace(engine.ACE_COMPAT, quantum_ladder=True, max_quantum=0.2)),
    ("ace-compat+sled-slope-friction", "ACE_COMPAT with the client's sledding friction test",
     dataclasses.replace(engine.ACE_COMPAT, sled_slope_friction=True)),
    ("ace-compat+sled-gravity", "ACE_COMPAT with gravity kept on a grounded sled",
     dataclasses.replace(engine.ACE_COMPAT, sled_gravity=True)),
    # the same settings again: its error is 0 by construction, its run time shows how much of the
    # differences between the other rows is machine noise
    ("ace-compat (repeat)", "ACE_COMPAT again: the noise control of the run-time column", engine.ACE_COMPAT),
]
KNOWN_FIELDS = {"max_steps", "ace_normals", "ace_outdoor_viewer", "single_precision", "step_length",
                "quantum_ladder", "max_quantum", "sled_slope_friction", "sled_gravity"}

TRACES = [
    "flat", "rolling", "steep", "cliff", "water",
    "cliff-viewer", "rolling-viewer", "steep-viewer",
    "cliff-longmove", "rolling-longmove", "steep-longmove",
    "cliff-missile", "rolling-missile", "steep-missile",
    "cliff-edgeslide",
    "house", "interior", "cellar", "dungeon",
    "house-viewer", "interior-viewer", "cellar-viewer", "dungeon-viewer",
    "house-missile", "house-ethereal", "interior-ethereal",
    "rolling-placement", "steep-placement", "cliff-placement",
    "house-placement", "interior-placement", "cellar-placement", "dungeon-placement",
    "objects", "objects-edgeslide", "objects-ethereal", "objects-missile", "objects-placement",
    "house-movers", "interior-movers", "rolling-movers", "objects-movers",
]
#: Traces to report apart (features being ported); empty since every shared trace replays.
PENDING_TRACES: list[str] = []


def all_settings() -> list[tuple[str, str, engine.EngineSettings]]:
    """SETTINGS, plus presets found in the settings module, plus one variant of
    the reference setting per EngineSettings field this file does not know
    (booleans flipped) - so a new knob is benchmarked the day it exists."""
    out = list(SETTINGS)
    seen = {s for _, _, s in out}  # (the repeat row is in SETTINGS on purpose)
    for name, value in sorted(vars(settings_module).items()):
        if isinstance(value, engine.EngineSettings) and value not in seen:
            out.append((name.lower().replace("_", "-"), f"preset {name} of engine/settings.py", value))
            seen.add(value)
    base = SETTINGS[0][2]
    for f in dataclasses.fields(engine.EngineSettings):
        if f.name in KNOWN_FIELDS:
            continue
        cur = getattr(base, f.name)
        if isinstance(cur, bool):
            variant = dataclasses.replace(base, **{f.name: not cur})
            if variant not in seen:
                out.append((f"{SETTINGS[0][0]}+{f.name}={not cur}".lower(), f"{SETTINGS[0][0]} with {f.name}={not cur} (new field)", variant))
                seen.add(variant)
    return out


def _global(pos: dict[str, Any]) -> tuple[float, float, float]:
    cell = int(pos["cell"], 16)
    x, y, z = (float(c) for c in pos["origin"])
    return (x + 192.0 * ((cell >> 24) & 0xFF), y + 192.0 * ((cell >> 16) & 0xFF), z)


def _dist(a: dict[str, Any] | None, b: dict[str, Any] | None) -> float:
    if a is None or b is None:
        return math.inf
    return math.dist(_global(a), _global(b))


def _contact_differs(a: dict[str, Any], b: dict[str, Any]) -> bool:
    return any(a.get(k) != b.get(k) for k in ("contact", "on_walkable") if k in a or k in b)


@dataclass
class Acc:
    """Per-setting accumulators."""

    times: list[float]
    err_ref: list[float]
    err_ref_unknown: list[float] = dataclasses.field(default_factory=list)  # cases not listed as known divergences
    contact_ref: int = 0
    err_base: list[float] = dataclasses.field(default_factory=list)
    contact_base: int = 0
    compared: int = 0
    exceptions: int = 0
    cases: int = 0


def _run_single(world: engine.World, case: dict[str, Any], settings: engine.EngineSettings) -> tuple[list[dict[str, Any]], list[float]]:
    from engine.formats.trace import add_case_mover, replay_move, result_to_expect, trace_vec

    saved = world.settings
    world.settings = settings
    mid = None
    clock = time.perf_counter_ns
    results: list[dict[str, Any]] = []
    times: list[float] = []
    try:
        mid = add_case_mover(world, case)
        physics = case.get("physics")
        dt = float(physics["dt"]) if physics else 0.0
        if physics and physics.get("velocity") is not None:
            world.mover(mid).velocity = trace_vec(physics["velocity"])
        for move in case["moves"]:
            t0 = clock()
            r = replay_move(world, mid, move, physics is not None, dt, False)
            times.append((clock() - t0) * 1e-9)
            results.append(result_to_expect(r, move["expect"].keys()))
            if move.get("placement") is not None and r.placement_result != "OK":  # type: ignore[attr-defined]
                break
        return results, times
    finally:
        world.settings = saved
        if mid is not None:
            world.remove_mover(mid)


def _run(world: engine.World, case: dict[str, Any], settings: engine.EngineSettings) -> tuple[list[tuple[dict[str, Any], dict[str, Any]]], list[float]]:
    """(expect, got) pairs and per-move seconds of one case."""
    if "movers" in case:
        t0 = time.perf_counter()
        res = engine.run_case(world, case, settings=settings)
        dt = time.perf_counter() - t0
        pairs = []
        for spec in case["movers"]:
            got = res.get(spec["id"], [])
            pairs += [(m["expect"], g) for m, g in zip(spec["moves"], got)]
        return pairs, [dt / max(1, len(pairs))] * len(pairs)
    got, times = _run_single(world, case, settings)
    return [(m["expect"], g) for m, g in zip(case["moves"], got)], times


def run(quick: bool, cases_per_trace: int | None = None, only_reference: bool = False,
        base_records: dict[str, list[Any]] | None = None) -> dict[str, Any]:
    """Replay the traces under every setting (only the first with `only_reference`).

    The result carries `base_records`: per case, the reference setting's final
    (global position, contact, on_walkable) of every move, so that another run
    (the pure-Python engine in another process) can be compared with this one;
    given `base_records`, this run's rows are compared against those instead.
    """
    settings = all_settings()[:1] if only_reference else all_settings()
    records: dict[str, list[Any]] = {}
    case_max: dict[str, float] = {}
    known = set(known_divergent())
    limit = cases_per_trace if cases_per_trace is not None else (3 if quick else None)
    accs = {name: Acc([], []) for name, _, _ in settings}
    pending_accs = {name: Acc([], []) for name, _, _ in settings}
    skipped: dict[str, str] = {}
    per_trace: dict[str, dict[str, Any]] = {}
    for group, names, target in (("main", TRACES, accs), ("pending", PENDING_TRACES, pending_accs)):
        for tname in names:
            try:
                trace = common.load_trace(tname)
                worlds = {name: engine.load_scene(common.ORACLE / "scenes" / trace["scene"], settings=s)
                          for name, _, s in settings}
            except Exception as e:  # noqa: BLE001
                skipped[tname] = f"{type(e).__name__}: {e}"
                continue
            cases = trace["cases"][:limit] if limit else trace["cases"]
            tr = per_trace.setdefault(tname, {"group": group, "moves": 0, "max_err_ref": {}, "exceptions": 0})
            for case in cases:
                base_pairs: list[tuple[dict[str, Any], dict[str, Any]]] | None = None
                for name, _, s in settings:
                    acc = target[name]
                    try:
                        pairs, times = _run(worlds[name], case, s)
                    except Exception as e:  # noqa: BLE001 - counted and reported
                        acc.exceptions += 1
                        tr["exceptions"] += 1
                        skipped.setdefault(f"{case['id']} ({name})", f"{type(e).__name__}: {e}")
                        continue
                    acc.cases += 1
                    acc.times += times
                    if name == settings[0][0]:
                        records[case["id"]] = [[list(_global(g["position"])) if g.get("position") else None,
                                                g.get("contact"), g.get("on_walkable")] for _, g in pairs]
                    outside = base_records.get(case["id"]) if base_records is not None else None
                    for i, (exp, got) in enumerate(pairs):
                        if outside is not None and i < len(outside):
                            b_pos, b_contact, b_walk = outside[i]
                            g_pos = _global(got["position"]) if got.get("position") else None
                            acc.err_base.append(math.dist(b_pos, g_pos) if b_pos and g_pos else (0.0 if b_pos == g_pos else math.inf))
                            acc.contact_base += (b_contact, b_walk) != (got.get("contact"), got.get("on_walkable"))
                            acc.compared += 1
                        d = _dist(exp.get("position"), got.get("position")) if "position" in exp else 0.0
                        acc.err_ref.append(d)
                        if case["id"] not in known:
                            acc.err_ref_unknown.append(d)
                        acc.contact_ref += _contact_differs(exp, got)
                        tr["max_err_ref"][name] = max(tr["max_err_ref"].get(name, 0.0), d)
                        if name == settings[0][0]:
                            case_max[case["id"]] = max(case_max.get(case["id"], 0.0), d)
                            tr["over_1e-4"] = tr.get("over_1e-4", 0) + (d > 1e-4)
                        if base_pairs is not None and i < len(base_pairs):
                            b = base_pairs[i][1]
                            acc.err_base.append(_dist(b.get("position"), got.get("position")) if "position" in b else 0.0)
                            acc.contact_base += _contact_differs(b, got)
                            acc.compared += 1
                    if base_pairs is None and name == settings[0][0]:
                        base_pairs = pairs
                        tr["moves"] += len(pairs)
            log(f"error: {tname:20s} {tr['moves']:6d} moves  max err (ref setting) {tr['max_err_ref'].get(settings[0][0], math.nan):.3g} m")
    from . import bench_retail

    return {
        "retail_corrections": bench_retail.run(quick) if not only_reference else None,
        "reference_setting": settings[0][0],
        "cases_per_trace": limit,
        "settings": [_row(name, desc, s, accs[name]) for name, desc, s in settings],
        "pending": [_row(name, desc, s, pending_accs[name]) for name, desc, s in settings],
        "per_trace": per_trace,
        "skipped": skipped,
        "base_records": records,
        "worst_cases": sorted(([k, v] for k, v in case_max.items() if v > 1e-3), key=lambda kv: -kv[1]),
        "known_divergent": known_divergent(),
    }


def known_divergent() -> list[str]:
    """The case ids tests/test_trace_replay.py lists as known divergences (read, not imported)."""
    import ast

    path = common.ROOT / "tests" / "test_trace_replay.py"
    try:
        tree = ast.parse(path.read_text(encoding="utf-8"))
    except (OSError, SyntaxError):
        return []
    for node in ast.walk(tree):
        value: ast.expr | None
        if isinstance(node, ast.Assign):
            target, value = node.targets[0], node.value
        elif isinstance(node, ast.AnnAssign):
            target, value = node.target, node.value
        else:
            continue
        if isinstance(target, ast.Name) and target.id == "KNOWN_DIVERGENT" and value is not None:
            try:
                return sorted(ast.literal_eval(value))
            except ValueError:
                return []
    return []


def _row(name: str, desc: str, s: engine.EngineSettings, a: Acc) -> dict[str, Any]:
    n = len(a.err_ref)
    finite = [e for e in a.err_ref if math.isfinite(e)]
    return {
        "name": name,
        "description": desc,
        "settings": dataclasses.asdict(s),
        "moves": n,
        "cases": a.cases,
        "exceptions": a.exceptions,
        "us_median": pct(a.times, 50) * 1e6 if a.times else math.nan,
        "us_mean": sum(a.times) / len(a.times) * 1e6 if a.times else math.nan,
        "total_s": sum(a.times),
        "err_ref": {"median": pct(finite, 50), "p99": pct(finite, 99), "max": max(finite) if finite else math.nan,
                    "missing": n - len(finite), "over_1e-4": sum(1 for e in finite if e > 1e-4),
                    "over_1e-3": sum(1 for e in finite if e > 1e-3)},
        "err_ref_without_known": {"moves": len(a.err_ref_unknown), "p99": pct([e for e in a.err_ref_unknown if math.isfinite(e)], 99),
                                  "max": max((e for e in a.err_ref_unknown if math.isfinite(e)), default=math.nan)},
        "contact_ref_frac": a.contact_ref / n if n else math.nan,
        "err_base": {"median": pct(a.err_base, 50), "p99": pct(a.err_base, 99),
                     "max": max(a.err_base) if a.err_base else math.nan,
                     "nonzero": sum(1 for e in a.err_base if e != 0.0)},
        "contact_base_frac": a.contact_base / a.compared if a.compared else math.nan,
    }


def pareto(rows: list[dict[str, Any]], x: str = "us_mean", y: str = "p99") -> list[str]:
    """Names of the settings no other setting beats on both run time and p99 error."""
    pts = [(r[x], r["err_ref"][y], r["name"]) for r in rows
           if r["moves"] and r[x] is not None and math.isfinite(r[x]) and r["err_ref"][y] is not None
           and not r["name"].endswith("(repeat)")]
    front = []
    for xi, yi, n in pts:
        if not any((xj <= xi and yj <= yi) and (xj < xi or yj < yi) for xj, yj, _ in pts):
            front.append(n)
    return front
