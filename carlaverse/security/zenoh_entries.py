"""Raw Zenoh config entries for TLS, user/password login and access control.

`FabricSettings.zenoh` takes json5 path -> value entries applied last; these helpers build
them with the exact zenoh 1.10 names, so no other module spells a TLS option.

Facts about zenoh 1.10 these encode (each verified with real sessions):
- mutual TLS needs `enable_mtls: true` on *both* ends: a dialer without it sends no client
  certificate and the listener refuses it (`CertificateRequired`);
- the same `transport/link/tls` block serves `tls/` and `quic/` endpoints;
- user/password login is symmetric: if a listener has a dictionary, every dialer must log in,
  and a dialer with credentials cannot open a session to a listener without a dictionary.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

TLS = "transport/link/tls"
USRPWD = "transport/auth/usrpwd"


class CredentialError(ValueError):
    """A password file is missing or holds something Zenoh cannot use."""


def tls_entries(
    ca: Path,
    certificate: Path | None = None,
    private_key: Path | None = None,
    *,
    mtls: bool = True,
    listen: bool = False,
    verify_name: bool = True,
) -> dict[str, Any]:
    """TLS/QUIC settings: trust `ca`; present `certificate` when dialing (and listening)."""
    entries: dict[str, Any] = {
        f"{TLS}/root_ca_certificate": str(ca),
        f"{TLS}/enable_mtls": mtls,
        f"{TLS}/verify_name_on_connect": verify_name,
    }
    if certificate is not None and private_key is not None:
        entries[f"{TLS}/connect_certificate"] = str(certificate)
        entries[f"{TLS}/connect_private_key"] = str(private_key)
        if listen:
            entries[f"{TLS}/listen_certificate"] = str(certificate)
            entries[f"{TLS}/listen_private_key"] = str(private_key)
    return entries


def usrpwd_entries(
    user: str | None = None, password: str | None = None, dictionary_file: Path | None = None
) -> dict[str, Any]:
    """Login as `user` when dialing; check dialers against `dictionary_file` when listening."""
    entries: dict[str, Any] = {}
    if user is not None:
        _check_field(user, "username")
        entries[f"{USRPWD}/user"] = user
        entries[f"{USRPWD}/password"] = _check_field(password or "", "password")
    if dictionary_file is not None:
        entries[f"{USRPWD}/dictionary_file"] = str(dictionary_file)
    return entries


def acl_entries(access_control: dict[str, Any]) -> dict[str, Any]:
    return {"access_control": access_control}


def _check_field(value: str, what: str) -> str:
    # The dictionary file is `user:password` per line; neither may break that format.
    bad = not value or "\n" in value or "\r" in value or (what == "username" and ":" in value)
    if bad:
        raise CredentialError(f"invalid {what}: must be non-empty, one line (usernames: no ':')")
    return value


def read_password(path: Path) -> str:
    """The password in `path` (first line, surrounding whitespace stripped)."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise CredentialError(
            f"cannot read password file {path}: {exc.strerror}; create the session's "
            "password files with: carlaverse roster passwords ROSTER"
        ) from exc
    lines = text.strip().splitlines()
    if not lines or not lines[0].strip():
        raise CredentialError(f"password file {path} is empty")
    return lines[0].strip()


def dictionary_text(logins: list[tuple[str, str]]) -> str:
    """Zenoh's user/password dictionary: `user:password` per line."""
    return "".join(
        f"{_check_field(user, 'username')}:{_check_field(password, 'password')}\n"
        for user, password in logins
    )


def write_private(path: Path, content: str | bytes) -> Path:
    """Write a secret file readable by its owner only (0600, never wider, not even briefly).

    The mode is set on the open descriptor before any byte is written, because an existing
    file keeps its old mode through O_CREAT and would hold the new secret world-readable.
    A missing directory is created 0700.
    """
    path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
    os.fchmod(fd, 0o600)
    data = content.encode("utf-8") if isinstance(content, str) else content
    with os.fdopen(fd, "wb") as handle:
        handle.write(data)
    return path
