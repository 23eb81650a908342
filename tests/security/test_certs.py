"""The test CA: chains verify, names land where Zenoh looks, private keys stay private."""

from __future__ import annotations

import datetime as dt
import ipaddress
import stat
from pathlib import Path

import pytest
from cryptography import x509
from cryptography.x509.oid import ExtendedKeyUsageOID

from carlaverse.keys import KeySpaceError
from carlaverse.security.certs import (
    CertificateError,
    SubjectAltNames,
    common_name,
    ensure_authority,
    issue_to_directory,
    load_authority,
    load_certificate,
)

NOW = dt.datetime(2026, 1, 1, tzinfo=dt.UTC)


def test_leaf_chains_to_the_ca_with_its_name_as_common_name(tmp_path: Path) -> None:
    ca, created = ensure_authority(tmp_path, "lab-ca", NOW)
    files = issue_to_directory(
        ca, tmp_path, "tum-drive-1", SubjectAltNames(("tum.example.org",), ("10.0.0.7",)), NOW
    )
    leaf = load_certificate(files.certificate)
    leaf.verify_directly_issued_by(ca.certificate)
    assert created and common_name(files.certificate) == "tum-drive-1"
    san = leaf.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    assert san.get_values_for_type(x509.DNSName) == ["tum.example.org"]
    assert san.get_values_for_type(x509.IPAddress) == [ipaddress.ip_address("10.0.0.7")]
    usages = leaf.extensions.get_extension_for_class(x509.ExtendedKeyUsage).value
    assert {ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH} <= set(usages)
    assert leaf.not_valid_before_utc < NOW < leaf.not_valid_after_utc


def test_private_keys_are_owner_only(tmp_path: Path) -> None:
    ca, _ = ensure_authority(tmp_path, "lab-ca", NOW)
    files = issue_to_directory(ca, tmp_path, "tum", SubjectAltNames(), NOW)
    for key in (files.private_key, tmp_path / "ca.key"):
        assert stat.S_IMODE(key.stat().st_mode) == 0o600


def test_the_ca_is_reused_not_replaced(tmp_path: Path) -> None:
    first, _ = ensure_authority(tmp_path, "lab-ca", NOW)
    again, created = ensure_authority(tmp_path, "other-name", NOW)
    assert not created
    assert again.certificate == first.certificate == load_authority(tmp_path).certificate


def test_names_that_could_widen_an_acl_are_refused(tmp_path: Path) -> None:
    ca, _ = ensure_authority(tmp_path, "lab-ca", NOW)
    with pytest.raises(KeySpaceError):
        issue_to_directory(ca, tmp_path, "evil/**", SubjectAltNames(), NOW)


def test_unreadable_files_name_the_file_and_the_fix(tmp_path: Path) -> None:
    with pytest.raises(CertificateError, match=r"ca\.pem"):
        load_authority(tmp_path)
    (tmp_path / "bad.pem").write_text("not a certificate")
    with pytest.raises(CertificateError, match=r"bad\.pem"):
        common_name(tmp_path / "bad.pem")
    with pytest.raises(CertificateError, match="SAN IP"):
        SubjectAltNames(ips=("not-an-ip",)).extension()
