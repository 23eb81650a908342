"""The one rule for what in a config is secret, and how it is blanked before it leaves.

A node's effective config travels: the node sends it in `JoinRequest.config_yaml`, the
authority serves it on `authority/configs`, recordings archive it and `replay` serves it
again. With `--roster` that config holds the router login (`fabric.zenoh` gets
`transport/auth/usrpwd/password`), so every one of those places applies `redact` first.

What counts as secret, wherever it sits in the config:
- everything under Zenoh's `transport/auth` (logins, user/password dictionaries), whether
  the path is nested mappings or flat json5 keys such as `"transport/auth/usrpwd/password"`;
- any value whose name says secret: password, passwd, pwd, secret, token, credential,
  usrpwd, private key, api/access/signing key;
- any string holding PEM private-key material, whatever its name.

Redaction keeps the structure (keys stay, values become `REDACTED`), so an archived config
still shows *that* a login or key was configured, never what it was.
"""

from __future__ import annotations

import itertools
import re
from collections.abc import Mapping
from typing import Any

import yaml

REDACTED = "<redacted>"
UNREADABLE = "# config withheld: not readable YAML, so its secrets could not be removed\n"

_SECRET_WORDS = frozenset(
    {"password", "passwd", "pwd", "secret", "secrets", "token", "credential", "credentials"}
    | {"usrpwd", "privkey"}
)
_KEY_QUALIFIERS = frozenset({"private", "api", "access", "signing", "secret"})
_WORD_SPLIT = re.compile(r"[_\-.\s]+")
_PEM_PRIVATE = re.compile(r"-----BEGIN [A-Z0-9 ]*PRIVATE KEY-----")


def is_secret_name(name: str) -> bool:
    """True for a config key that names secret material (`connect_private_key`, `password`)."""
    words = [w for w in _WORD_SPLIT.split(name.lower()) if w]
    if any(w in _SECRET_WORDS for w in words):
        return True
    return any(a in _KEY_QUALIFIERS and b == "key" for a, b in itertools.pairwise(words))


def _is_secret_path(segments: tuple[str, ...]) -> bool:
    # Zenoh's auth block holds nothing but credentials: every value under it is secret.
    pairs = itertools.pairwise(segments)
    return any(a == "transport" and b == "auth" for a, b in pairs) or any(
        is_secret_name(s) for s in segments
    )


def redact(value: Any, path: tuple[str, ...] = ()) -> Any:
    """A copy of builtins `value` (mappings, lists, scalars) with every secret blanked."""
    if isinstance(value, Mapping):
        return {k: redact(v, (*path, *str(k).split("/"))) for k, v in value.items()}
    if _is_secret_path(path):
        return _blank(value)
    if isinstance(value, list | tuple):
        return [redact(v, path) for v in value]
    if isinstance(value, str) and _PEM_PRIVATE.search(value):
        return REDACTED
    return value


def _blank(value: Any) -> Any:
    """Every leaf of a secret value blanked; booleans and nulls are settings, not secrets."""
    if isinstance(value, list | tuple):
        return [_blank(v) for v in value]
    if value is None or isinstance(value, bool):
        return value
    return REDACTED


def redact_yaml(text: str) -> str:
    """`text` with its secrets blanked; unchanged (byte for byte) if it holds none.

    Text that is not readable YAML cannot be checked, so it is withheld entirely.
    """
    try:
        data = yaml.safe_load(text)
        cleaned = redact(data)
    except (yaml.YAMLError, RecursionError):
        return UNREADABLE
    if cleaned == data:
        return text
    return yaml.safe_dump(cleaned, sort_keys=False)
