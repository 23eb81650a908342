"""Raw Zenoh entries: exact 1.10 option names, and secrets that cannot break their file format."""

from __future__ import annotations

import stat
from pathlib import Path

import pytest
import zenoh

from carlaverse.security.zenoh_entries import (
    CredentialError,
    dictionary_text,
    read_password,
    tls_entries,
    usrpwd_entries,
    write_private,
)
from carlaverse.transport.session import FabricSettings, build_config


def test_entries_are_accepted_by_zenoh(tmp_path: Path) -> None:
    entries = {
        **tls_entries(tmp_path / "ca.pem", tmp_path / "x.pem", tmp_path / "x.key", listen=True),
        **usrpwd_entries("x", "secret", tmp_path / "dict"),
    }
    config = build_config(FabricSettings(zenoh=entries))
    assert isinstance(config, zenoh.Config)
    tls = config.get_json("transport/link/tls")
    assert '"enable_mtls":true' in tls and "x.key" in tls


def test_dictionary_lines_and_bad_credentials() -> None:
    assert dictionary_text([("a", "p:1"), ("b", "q")]) == "a:p:1\nb:q\n"
    for user, password in (("a:b", "p"), ("a", "two\nlines"), ("", "p"), ("a", "")):
        with pytest.raises(CredentialError):
            dictionary_text([(user, password)])


def test_password_files(tmp_path: Path) -> None:
    path = write_private(tmp_path / "s" / "x.password", "  hunter2  \nignored\n")
    assert read_password(path) == "hunter2"
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    path.chmod(0o644)
    write_private(path, "new\n")  # rewriting tightens an existing file's mode too
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    with pytest.raises(CredentialError, match="carlaverse roster passwords"):
        read_password(tmp_path / "missing.password")
    (tmp_path / "empty.password").write_text("\n")
    with pytest.raises(CredentialError, match="empty"):
        read_password(tmp_path / "empty.password")
