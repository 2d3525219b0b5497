"""How the service's log lines look: `--log-level` and `--log-format text|json`.

Text is one line per record, `time LEVEL logger: message`. JSON is one
object per line, for log shippers: `time` (UTC, ISO 8601 with
milliseconds), `level`, `logger`, `message`, `pid`, the record's
structured fields when it has them (service/bus/request_log.py: `op`, `key`,
`items`, `result`, `ms`, `kind`, ...) and `exception` (the traceback's
text) when one was logged.
"""

from __future__ import annotations

import argparse
import json
import logging
import time
from typing import Any

__all__ = ["LOG_FORMATS", "LOG_LEVELS", "JsonFormatter", "add_log_arguments", "configure_logging"]

LOG_LEVELS = ("DEBUG", "INFO", "WARNING", "ERROR")
LOG_FORMATS = ("text", "json")
TEXT_FORMAT = "%(asctime)s %(levelname)s %(name)s: %(message)s"
#: the record attribute that carries a line's structured fields (`extra={FIELDS: {...}}`)
FIELDS = "fields"


def add_log_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--log-level", default="INFO", choices=LOG_LEVELS,
                   help="the least severe log lines written to stderr (default %(default)s; DEBUG: one line per "
                        "request)")
    p.add_argument("--log-format", default="text", choices=LOG_FORMATS,
                   help="text lines, or one JSON object per line for log shippers (default %(default)s)")


class JsonFormatter(logging.Formatter):
    """One JSON object per record, on one line."""

    def format(self, record: logging.LogRecord) -> str:
        out: dict[str, Any] = {
            "time": time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(record.created)) + f".{int(record.msecs):03d}Z",
            "level": record.levelname,
            "logger": record.name,
            "message": record.getMessage(),
            "pid": record.process,
        }
        fields = getattr(record, FIELDS, None)
        if isinstance(fields, dict):
            out.update({k: v for k, v in fields.items() if k not in out})
        if record.exc_info:
            out["exception"] = self.formatException(record.exc_info)
        return json.dumps(out, default=str, ensure_ascii=False)


def configure_logging(level: str, fmt: str = "text") -> None:
    """The root logger's level and a stderr handler in `fmt` (a no-op when logging is configured already,
    as `logging.basicConfig` is)."""
    handler = logging.StreamHandler()
    handler.setFormatter(JsonFormatter() if fmt == "json" else logging.Formatter(TEXT_FORMAT))
    logging.basicConfig(level=level, handlers=[handler])
