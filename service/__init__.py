"""The acphys service: the engine on a Zenoh bus (protocol in docs/protocol.md).

The bus layer (node, main) imports zenoh; wire, validate, codec and
requests do not, and the client library reuses them.
"""

from service.protocol.wire import PROTOCOL_VERSION, ErrorKind, Keys

__all__ = ["PROTOCOL_VERSION", "ErrorKind", "Keys"]
