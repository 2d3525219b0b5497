"""A cluster of service instances for tests: a throwaway CA, an instance certificate, cluster files.

Certificates are made here with the `cryptography` package (a test dependency), valid for two days,
for 127.0.0.1 and localhost; nothing is read from or written outside the test's own directory.
"""

from __future__ import annotations

import datetime
import ipaddress
import json
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import NameOID

from service_support import endpoint, free_port

INSTANCE_CN = "acphys-instance"


def _name(cn: str) -> x509.Name:
    return x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, cn)])


def _write_key(key: ec.EllipticCurvePrivateKey, path: Path) -> None:
    path.write_bytes(key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8,
                                       serialization.NoEncryption()))


def make_certificates(out: Path, names: tuple[str, ...] = (INSTANCE_CN,), ca_cn: str = "acphys-test-ca") -> Path:
    """`ca.pem` and, per name, `<name>.pem` + `<name>-key.pem` signed by it, in `out`; `out`."""
    out.mkdir(parents=True, exist_ok=True)
    now = datetime.datetime.now(datetime.timezone.utc)
    ca_key = ec.generate_private_key(ec.SECP256R1())
    ca = (x509.CertificateBuilder().subject_name(_name(ca_cn)).issuer_name(_name(ca_cn))
          .public_key(ca_key.public_key()).serial_number(x509.random_serial_number())
          .not_valid_before(now - datetime.timedelta(hours=1)).not_valid_after(now + datetime.timedelta(days=2))
          .add_extension(x509.BasicConstraints(ca=True, path_length=None), critical=True)
          .sign(ca_key, hashes.SHA256()))
    (out / "ca.pem").write_bytes(ca.public_bytes(serialization.Encoding.PEM))
    for cn in names:
        key = ec.generate_private_key(ec.SECP256R1())
        san = x509.SubjectAlternativeName([x509.DNSName("localhost"), x509.IPAddress(ipaddress.ip_address("127.0.0.1"))])
        cert = (x509.CertificateBuilder().subject_name(_name(cn)).issuer_name(ca.subject)
                .public_key(key.public_key()).serial_number(x509.random_serial_number())
                .not_valid_before(now - datetime.timedelta(hours=1)).not_valid_after(now + datetime.timedelta(days=2))
                .add_extension(san, critical=False)
                .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
                .sign(ca_key, hashes.SHA256()))
        (out / f"{cn}.pem").write_bytes(cert.public_bytes(serialization.Encoding.PEM))
        _write_key(key, out / f"{cn}-key.pem")
    return out


def tls_endpoint() -> str:
    return endpoint(free_port()).replace("tcp/", "tls/")


def cluster_file(directory: Path, name: str, listen: list[str], connect: list[str], cn: str = INSTANCE_CN) -> Path:
    """A cluster file for one instance, its certificates in `directory` (relative paths)."""
    path = directory / f"cluster-{name}.json"
    path.write_text(json.dumps({"ca": "ca.pem", "cert": f"{cn}.pem", "key": f"{cn}-key.pem",
                                "listen": listen, "connect": connect}))
    return path


def cluster_pair(directory: Path) -> tuple[list[str], list[str]]:
    """Two instances' `extra` arguments: A listens on a TLS endpoint, B connects to it."""
    make_certificates(directory)
    a_tls, b_tls = tls_endpoint(), tls_endpoint()
    a = cluster_file(directory, "a", [a_tls], [])
    b = cluster_file(directory, "b", [b_tls], [a_tls])
    return ["--cluster", str(a)], ["--cluster", str(b)]
