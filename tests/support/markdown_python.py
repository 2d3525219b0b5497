"""Run a Markdown file's ```python blocks as a reader pastes them: in order, in one Python session.

Used by the tests that keep README.md's walk-through and docs/client.md's example working.
"""

from __future__ import annotations

import contextlib
import io
import re
import traceback
from typing import Any

__all__ = ["python_blocks", "run_blocks"]

_BLOCK = re.compile(r"^```python\n(.*?)^```$", re.MULTILINE | re.DOTALL)


def python_blocks(text: str) -> list[str]:
    """The ```python blocks of a Markdown text, in order."""
    return [m.group(1) for m in _BLOCK.finditer(text)]


def run_blocks(blocks: list[str], replacements: dict[str, str]) -> dict[str, Any]:
    """Run the blocks in order in one namespace, each with `replacements` made in its text; the namespace
    after the last. AssertionError naming the block (its number among `blocks`), with its traceback and
    what the blocks printed, when one raises."""
    namespace: dict[str, Any] = {"__name__": "__markdown__"}
    printed = io.StringIO()
    for number, block in enumerate(blocks, 1):
        source = block
        for old, new in replacements.items():
            source = source.replace(old, new)
        try:
            code = compile(source, f"<python block {number}>", "exec")
            with contextlib.redirect_stdout(printed):
                exec(code, namespace)
        except Exception:
            raise AssertionError(f"python block {number} raised:\n{traceback.format_exc()}\n"
                                 f"block:\n{source}\nprinted so far:\n{printed.getvalue()}") from None
    return namespace
