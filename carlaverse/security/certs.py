"""A private certificate authority for a lab that has none (docs/architecture.md §12).

Every site router and every node gets an ECDSA P-256 certificate signed by the session CA,
with its site name or node id as the subject common name: Zenoh's access control matches
`cert_common_names` against exactly that field. Leaf certificates carry both the server and
the client extended key usage, because a router listens (server) and dials other sites
(client) with the same identity.

Files in the output directory: `ca.pem`, `ca.key`, then `<name>.pem` / `<name>.key` per
identity. Private keys are PKCS#8 PEM (what rustls reads) and written with mode 0600.
"""

from __future__ import annotations

import datetime as dt
import ipaddress
from dataclasses import dataclass
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from carlaverse.keys import check_token
from carlaverse.security.zenoh_entries import write_private

CA_CERT_FILE = "ca.pem"
CA_KEY_FILE = "ca.key"
DEFAULT_VALID_DAYS = 365


class CertificateError(ValueError):
    """A certificate or key file is missing, unreadable or not what was expected."""


@dataclass(frozen=True, slots=True)
class SubjectAltNames:
    """Names a peer may dial this identity by; TLS verifies the dialled name against them."""

    dns: tuple[str, ...] = ("localhost",)
    ips: tuple[str, ...] = ("127.0.0.1",)

    def extension(self) -> x509.SubjectAlternativeName:
        try:
            ips = [x509.IPAddress(ipaddress.ip_address(ip)) for ip in self.ips]
        except ValueError as exc:
            raise CertificateError(f"invalid SAN IP address in {self.ips}: {exc}") from exc
        return x509.SubjectAlternativeName([*(x509.DNSName(d) for d in self.dns), *ips])


@dataclass(frozen=True, slots=True)
class CertificateFiles:
    """Where one identity's PEM files are."""

    certificate: Path
    private_key: Path


@dataclass(frozen=True, slots=True)
class Authority:
    """A CA in memory: its certificate and signing key."""

    certificate: x509.Certificate
    private_key: ec.EllipticCurvePrivateKey


def _name(common_name: str, organization: str) -> x509.Name:
    return x509.Name(
        [
            x509.NameAttribute(NameOID.ORGANIZATION_NAME, organization),
            x509.NameAttribute(NameOID.COMMON_NAME, common_name),
        ]
    )


def create_authority(
    common_name: str, now: dt.datetime, valid_days: int = DEFAULT_VALID_DAYS
) -> Authority:
    """A self-signed CA that may sign leaf certificates only (path length 0)."""
    key = ec.generate_private_key(ec.SECP256R1())
    name = _name(common_name, "CARLAverse session CA")
    builder = (
        x509.CertificateBuilder()
        .subject_name(name)
        .issuer_name(name)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - dt.timedelta(minutes=5))  # tolerate small clock skew
        .not_valid_after(now + dt.timedelta(days=valid_days))
        .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
        .add_extension(_ca_key_usage(), critical=True)
        .add_extension(x509.SubjectKeyIdentifier.from_public_key(key.public_key()), False)
    )
    return Authority(builder.sign(key, hashes.SHA256()), key)


def _ca_key_usage() -> x509.KeyUsage:
    return x509.KeyUsage(
        digital_signature=True,
        content_commitment=False,
        key_encipherment=False,
        data_encipherment=False,
        key_agreement=False,
        key_cert_sign=True,
        crl_sign=True,
        encipher_only=False,
        decipher_only=False,
    )


def _leaf_key_usage() -> x509.KeyUsage:
    return x509.KeyUsage(
        digital_signature=True,
        content_commitment=False,
        key_encipherment=False,
        data_encipherment=False,
        key_agreement=True,
        key_cert_sign=False,
        crl_sign=False,
        encipher_only=False,
        decipher_only=False,
    )


def issue_certificate(
    authority: Authority,
    common_name: str,
    sans: SubjectAltNames,
    now: dt.datetime,
    valid_days: int = DEFAULT_VALID_DAYS,
) -> tuple[x509.Certificate, ec.EllipticCurvePrivateKey]:
    """A leaf certificate for a site router or node, usable as TLS server and client."""
    check_token(common_name, "certificate common name")
    key = ec.generate_private_key(ec.SECP256R1())
    ca_public = authority.private_key.public_key()  # the certificate's, typed as EC
    builder = (
        x509.CertificateBuilder()
        .subject_name(_name(common_name, "CARLAverse"))
        .issuer_name(authority.certificate.subject)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - dt.timedelta(minutes=5))
        .not_valid_after(now + dt.timedelta(days=valid_days))
        .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
        .add_extension(_leaf_key_usage(), critical=True)
        .add_extension(
            x509.ExtendedKeyUsage(
                [ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]
            ),
            critical=False,
        )
        .add_extension(sans.extension(), critical=False)
        .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(ca_public), False)
    )
    return builder.sign(authority.private_key, hashes.SHA256()), key


def write_pair(
    certificate: x509.Certificate,
    key: ec.EllipticCurvePrivateKey,
    cert_path: Path,
    key_path: Path,
) -> CertificateFiles:
    """Write PEM files; the key is created 0600 so it is never readable by others, even briefly."""
    cert_path.parent.mkdir(parents=True, exist_ok=True)
    cert_path.write_bytes(certificate.public_bytes(serialization.Encoding.PEM))
    key_pem = key.private_bytes(
        serialization.Encoding.PEM,
        serialization.PrivateFormat.PKCS8,
        serialization.NoEncryption(),
    )
    write_private(key_path, key_pem)
    return CertificateFiles(cert_path, key_path)


def identity_files(directory: Path, name: str) -> CertificateFiles:
    """The conventional file names of one identity in a certificate directory."""
    return CertificateFiles(directory / f"{name}.pem", directory / f"{name}.key")


def ca_file(directory: Path) -> Path:
    return directory / CA_CERT_FILE


def load_authority(directory: Path) -> Authority:
    """Load `ca.pem` and `ca.key` from `directory`."""
    cert = load_certificate(directory / CA_CERT_FILE)
    key_path = directory / CA_KEY_FILE
    try:
        key = serialization.load_pem_private_key(key_path.read_bytes(), password=None)
    except (OSError, ValueError, TypeError) as exc:
        raise CertificateError(
            f"cannot load the CA key {key_path}: {exc}; "
            "create a CA with: carlaverse certs --out DIR --ca"
        ) from exc
    if not isinstance(key, ec.EllipticCurvePrivateKey):
        raise CertificateError(f"{key_path}: expected an EC private key, got {type(key).__name__}")
    return Authority(cert, key)


def ensure_authority(
    directory: Path, common_name: str, now: dt.datetime, valid_days: int = DEFAULT_VALID_DAYS
) -> tuple[Authority, bool]:
    """Load the CA in `directory`, or create and write one; returns (ca, created)."""
    if (directory / CA_CERT_FILE).exists():
        return load_authority(directory), False
    authority = create_authority(common_name, now, valid_days)
    write_pair(
        authority.certificate,
        authority.private_key,
        directory / CA_CERT_FILE,
        directory / CA_KEY_FILE,
    )
    return authority, True


def issue_to_directory(
    authority: Authority,
    directory: Path,
    common_name: str,
    sans: SubjectAltNames,
    now: dt.datetime,
    valid_days: int = DEFAULT_VALID_DAYS,
) -> CertificateFiles:
    """Issue a certificate for `common_name` and write `<name>.pem` / `<name>.key`."""
    cert, key = issue_certificate(authority, common_name, sans, now, valid_days)
    files = identity_files(directory, common_name)
    return write_pair(cert, key, files.certificate, files.private_key)


def load_certificate(path: Path) -> x509.Certificate:
    try:
        return x509.load_pem_x509_certificate(Path(path).read_bytes())
    except (OSError, ValueError) as exc:
        raise CertificateError(f"cannot load certificate {path}: {exc}") from exc


def common_name(path: Path) -> str:
    """The subject common name of a PEM certificate: the identity Zenoh's ACL sees."""
    names = load_certificate(path).subject.get_attributes_for_oid(NameOID.COMMON_NAME)
    if not names:
        raise CertificateError(f"certificate {path} has no common name")
    return str(names[0].value)
