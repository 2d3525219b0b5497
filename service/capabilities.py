"""What an instance understands, as Health announces it (docs/protocol.md, Health).

Later additions to protocol 1 are announced here so that a client can tell
an instance that knows them from an older one (which lacks the field).
One definition for a single instance and for a `--workers` service.
"""

from __future__ import annotations

from typing import Any

from service.protocol.columns import MOVE_FORMS
from service.protocol import QUERY_FORMS, QUERY_OPS
from service.protocol.requests import PUBLISH_MODES
from service.protocol.wire import PROTOCOL_VERSION

__all__ = ["CAPABILITY_FIELDS", "capabilities"]

#: Health's fields that say what the instance understands (not how it is doing)
CAPABILITY_FIELDS = ("protocol", "publish", "move_forms", "queries", "query_forms")


def capabilities() -> dict[str, Any]:
    return {
        "protocol": PROTOCOL_VERSION,
        "publish": list(PUBLISH_MODES),
        "move_forms": list(MOVE_FORMS),
        "queries": list(QUERY_OPS),
        "query_forms": list(QUERY_FORMS),
    }
