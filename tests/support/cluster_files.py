"""A cluster of service instances for tests: a throwaway CA, an instance certificate, cluster files.

Certificates are made by service/security/certificates.py (the `cryptography` package), valid for two days, for
127.0.0.1 and localhost; nothing is read from or written outside the test's own directory.
"""

from __future__ import annotations

import json
from pathlib import Path

from service.security.certificates import INSTANCE_CN, make_certificates
from support.service_harness import endpoint, free_port

__all__ = ["INSTANCE_CN", "make_certificates", "tls_endpoint", "cluster_file", "cluster_pair"]


def tls_endpoint() -> str:
    return endpoint(free_port()).replace("tcp/", "tls/")


def cluster_file(directory: Path, name: str, listen: list[str], connect: list[str], cn: str = INSTANCE_CN,
                 password: str | None = None) -> Path:
    """A cluster file for one instance, its certificates in `directory` (relative paths); `password`: the
    instances' password for accounts, written to `instance-password.txt` beside it."""
    path = directory / f"cluster-{name}.json"
    content: dict[str, object] = {"ca": "ca.pem", "cert": f"{cn}.pem", "key": f"{cn}-key.pem",
                                  "listen": listen, "connect": connect}
    if password is not None:
        (directory / "instance-password.txt").write_text(password + "\n", encoding="utf-8")
        content["password"] = "instance-password.txt"
    path.write_text(json.dumps(content))
    return path


def cluster_pair(directory: Path) -> tuple[list[str], list[str]]:
    """Two instances' `extra` arguments: A listens on a TLS endpoint, B connects to it."""
    make_certificates(directory)
    a_tls, b_tls = tls_endpoint(), tls_endpoint()
    a = cluster_file(directory, "a", [a_tls], [])
    b = cluster_file(directory, "b", [b_tls], [a_tls])
    return ["--cluster", str(a)], ["--cluster", str(b)]
