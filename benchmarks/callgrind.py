"""Running a Python script under valgrind's callgrind and reading back the instructions it counted.

`run_counted` runs `python -c script` in a checkout under callgrind (the options say where counting is
switched on) and returns the child's `RESULT {json}` line with the instruction total; `totals_of` reads that
total from callgrind's output file; `python_of` is the checkout's own interpreter. Shared by
benchmarks/bench_instructions.py (engine calls on the reference traces) and benchmarks/instructions_service.py
(the service's column path), which import it and not each other.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

__all__ = ["run_counted", "totals_of", "per_unit", "python_of", "CHILD_TIMEOUT_S"]

#: seconds a counted child may run before it is given up
CHILD_TIMEOUT_S = 1800.0

_TOTALS = re.compile(r"^(?:totals|summary):\s+(\d+)\s*$", re.MULTILINE)


def totals_of(callgrind_out: str) -> int:
    """The instruction total of a callgrind output file's text (its `totals:` or `summary:` line)."""
    m = _TOTALS.search(callgrind_out)
    if m is None:
        raise ValueError("no totals line in the callgrind output")
    return int(m.group(1))


def per_unit(low: int, high: int, units: tuple[int, int]) -> float:
    """Instructions per unit of work (a move, a call) from the counts of a short run (`low`, `units[0]`
    units) and a long one (`high`, `units[1]`): start-up and loading are in both and cancel out."""
    return (high - low) / (units[1] - units[0])


def python_of(root: Path) -> str:
    """The python of `root`'s .venv (this interpreter when it has none)."""
    venv = root / ".venv" / "bin" / "python"
    return str(venv) if venv.exists() else sys.executable


def run_counted(python: str, root: Path, script: str, args: list[str], options: list[str],
                env: dict[str, str] | None = None) -> tuple[dict[str, Any], int]:
    """`python -c script root args...` under callgrind with `options`, in `root`: the child's `RESULT {json}`
    and the instructions counted. The hash seed is fixed, so a run counts the same every time."""
    with tempfile.TemporaryDirectory(prefix="acphys-callgrind-") as tmp:
        out = Path(tmp) / "callgrind.out"
        cmd = ["valgrind", "--tool=callgrind", *options, f"--callgrind-out-file={out}", python, "-c", script,
               str(root), *args]
        child_env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1", PYTHONHASHSEED="0", **(env or {}))
        child_env.pop("PYTHONPATH", None)
        p = subprocess.run(cmd, cwd=root, env=child_env, capture_output=True, text=True, timeout=CHILD_TIMEOUT_S)
        lines = [ln for ln in p.stdout.splitlines() if ln.startswith("RESULT ")]
        if p.returncode != 0 or not lines or not out.exists():
            raise RuntimeError(f"callgrind run of {args} with {root} failed ({p.returncode}): {p.stderr[-800:]}")
        result: dict[str, Any] = json.loads(lines[-1][7:])
        return result, totals_of(out.read_text())
