"""Formatting shared by the report's sections (benchmarks/report.py, benchmarks/report_service.py)."""

from __future__ import annotations

import math
from typing import Any

from . import common
from .common import fmt

__all__ = ["PLOTS", "REL", "as_float", "num", "sci", "pct", "verdict_of", "ratio", "pyplot", "save_plot", "meta_line"]

PLOTS = common.ROOT / "benchmarks" / "plots"


REL = "../benchmarks/plots"  # from docs/


def as_float(x: Any) -> float:
    return math.nan if x is None else float(x)


def num(x: Any, d: int = 1) -> str:
    return fmt(as_float(x), d)


def sci(x: Any) -> str:
    """An error in metres."""
    x = as_float(x)
    if math.isnan(x):
        return "n/a"
    if x == 0.0:
        return "0"
    return f"{x:.2g}"


def pct(x: Any) -> str:
    x = as_float(x)
    return "n/a" if math.isnan(x) else f"{100.0 * x:.2f} %"


def verdict_of(value: float, limit: float) -> str:
    """'met' when value <= limit, else by how many times it misses."""
    return "met" if value <= limit else f"missed by {value / limit:.1f}x"


def ratio(x: Any) -> str:
    return "" if not x else f"{x:.1f}x"


def pyplot() -> Any:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        return plt
    except ImportError:
        return None


def meta_line(sec: dict[str, Any]) -> str:
    m = sec.get("meta", {})
    mach = m.get("machine", {})
    return (f"Measured by `{m.get('command', '?')}` at {m.get('started', '?')} on commit {m.get('commit', '?')} "
            f"({mach.get('cpus', '?')} CPUs, {mach.get('cpu', '?')}, Python {mach.get('python', '?')}; "
            f"load average at start {', '.join(f'{x:.2f}' for x in mach.get('loadavg_at_start', []))}); "
            f"took {m.get('seconds', 0):.0f} s{' (quick run)' if m.get('quick') else ''}. "
            + (f"The working tree's engine ran compiled ({len(mach['compiled_engine_modules'])} modules)."
               if mach.get("compiled_engine_modules") else "The working tree's engine ran interpreted (no compiled modules)."))


def save_plot(plt: Any, fig: Any, name: str) -> str:
    """Write `fig` to benchmarks/plots/`name` and close it; its path as docs/ links it."""
    fig.tight_layout()
    PLOTS.mkdir(parents=True, exist_ok=True)
    fig.savefig(PLOTS / name, dpi=90)
    plt.close(fig)
    return f"{REL}/{name}"
