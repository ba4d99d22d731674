"""The site's certificate authority and one certificate per component, with ``cryptography``.

Keys are ECDSA P-256; certificates are X.509 v3 (rustls, which Zenoh uses, refuses v1 client
certificates). The router's certificate names every host clients dial (subjectAltName: DNS
names and IP addresses) and serves TLS; a component's certificate carries the component's name
as its common name, which the router's ACL matches (``cert_common_names``), so the certificate
is the component's credential. Private keys are written with mode 0600, the directory 0700.
What exists is reused: a CA is made once per site, a certificate again only when missing,
unreadable, expiring within ``renew_before`` or (for the router) missing a host.
"""

from __future__ import annotations

import datetime
import ipaddress
import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from ._errors import SecureError

__all__ = ["CertFiles", "CertificateAuthority"]

_DAY = datetime.timedelta(days=1)


@dataclass(frozen=True)
class CertFiles:
    """A certificate and its private key, as PEM files."""

    cert: Path
    key: Path


def _write_private(path: Path, data: bytes) -> None:
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    with os.fdopen(fd, "wb") as out:
        out.write(data)


def _key_pem(key: ec.EllipticCurvePrivateKey) -> bytes:
    return key.private_bytes(
        serialization.Encoding.PEM,
        serialization.PrivateFormat.PKCS8,
        serialization.NoEncryption(),
    )


def _alt_name(host: str) -> x509.GeneralName:
    try:
        return x509.IPAddress(ipaddress.ip_address(host))
    except ValueError:
        return x509.DNSName(host)


class CertificateAuthority:
    """The site CA in ``folder`` (``ca.pem``, ``ca-key.pem``), made on first use."""

    def __init__(self, folder: Path, *, site: str = "skimesh site", days: int = 3650) -> None:
        self.folder = folder
        folder.mkdir(parents=True, exist_ok=True)
        folder.chmod(0o700)
        self.files = CertFiles(folder / "ca.pem", folder / "ca-key.pem")
        if self.files.cert.exists() and self.files.key.exists():
            self.cert, self.key = self._load(self.files)
            return
        self.key = ec.generate_private_key(ec.SECP256R1())
        name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, f"{site} CA")])
        now = datetime.datetime.now(datetime.UTC)
        self.cert = (
            x509.CertificateBuilder()
            .subject_name(name)
            .issuer_name(name)
            .public_key(self.key.public_key())
            .serial_number(x509.random_serial_number())
            .not_valid_before(now - _DAY)
            .not_valid_after(now + days * _DAY)
            .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
            .add_extension(
                x509.KeyUsage(
                    digital_signature=True,
                    key_cert_sign=True,
                    crl_sign=True,
                    content_commitment=False,
                    key_encipherment=False,
                    data_encipherment=False,
                    key_agreement=False,
                    encipher_only=False,
                    decipher_only=False,
                ),
                critical=True,
            )
            .sign(self.key, hashes.SHA256())
        )
        _write_private(self.files.key, _key_pem(self.key))
        self.files.cert.write_bytes(self.cert.public_bytes(serialization.Encoding.PEM))

    @staticmethod
    def _load(files: CertFiles) -> tuple[x509.Certificate, ec.EllipticCurvePrivateKey]:
        try:
            cert = x509.load_pem_x509_certificate(files.cert.read_bytes())
            key = serialization.load_pem_private_key(files.key.read_bytes(), password=None)
        except (ValueError, OSError) as e:
            raise SecureError(f"the site CA in {files.cert.parent} cannot be read: {e}") from e
        if not isinstance(key, ec.EllipticCurvePrivateKey):
            raise SecureError(f"{files.key} is no ECDSA key")
        return cert, key

    def issue(
        self,
        name: str,
        *,
        hosts: Sequence[str] = (),
        client: bool = True,
        days: int = 825,
        renew_before: int = 30,
    ) -> CertFiles:
        """``<name>.pem`` / ``<name>-key.pem`` signed by this CA, whose common name is
        ``name``: for TLS servers on ``hosts`` when given (the router; ``client`` too: it also
        dials other routers), else for a client. An existing one is kept unless it must be
        renewed (see the module doc)."""
        files = CertFiles(self.folder / f"{name}.pem", self.folder / f"{name}-key.pem")
        if self._still_good(files, hosts, renew_before):
            return files
        key = ec.generate_private_key(ec.SECP256R1())
        now = datetime.datetime.now(datetime.UTC)
        usages = [ExtendedKeyUsageOID.SERVER_AUTH] if hosts else []
        if client or not hosts:
            usages.append(ExtendedKeyUsageOID.CLIENT_AUTH)
        builder = (
            x509.CertificateBuilder()
            .subject_name(x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, name)]))
            .issuer_name(self.cert.subject)
            .public_key(key.public_key())
            .serial_number(x509.random_serial_number())
            .not_valid_before(now - _DAY)
            .not_valid_after(now + days * _DAY)
            .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
            .add_extension(x509.ExtendedKeyUsage(usages), critical=False)
        )
        if hosts:
            builder = builder.add_extension(
                x509.SubjectAlternativeName([_alt_name(h) for h in hosts]), critical=False
            )
        cert = builder.sign(self.key, hashes.SHA256())
        _write_private(files.key, _key_pem(key))
        files.cert.write_bytes(cert.public_bytes(serialization.Encoding.PEM))
        return files

    def _still_good(self, files: CertFiles, hosts: Sequence[str], renew_before: int) -> bool:
        if not (files.cert.exists() and files.key.exists()):
            return False
        try:
            cert = x509.load_pem_x509_certificate(files.cert.read_bytes())
        except ValueError:
            return False
        left = cert.not_valid_after_utc - datetime.datetime.now(datetime.UTC)
        if left < renew_before * _DAY or cert.issuer != self.cert.subject:
            return False
        if not hosts:
            return True
        try:
            names = cert.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
        except x509.ExtensionNotFound:
            return False
        have = {str(n.value) for n in names}
        return all(str(_alt_name(h).value) in have for h in hosts)
