"""An in-process service for commands that need one and find none running."""

from __future__ import annotations

import socket
from pathlib import Path

from service.bus.node import NodeOptions, ServiceNode
from service.world_source import open_world
from service.bus.zconfig import make_config

__all__ = ["EmbeddedService", "free_loopback_port"]


def free_loopback_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class EmbeddedService:
    """A ServiceNode on a free loopback port, serving a scene; use as a context manager."""

    def __init__(self, scene: str | Path, prefix: str = "acphys") -> None:
        self.endpoint = f"tcp/127.0.0.1:{free_loopback_port()}"
        self.node = ServiceNode(open_world(scene=str(scene)), make_config(listen=[self.endpoint]), NodeOptions(prefix=prefix))

    def __enter__(self) -> EmbeddedService:
        self.node.start()
        return self

    def __exit__(self, *_: object) -> None:
        self.node.shutdown()
