"""The one redaction rule: what is secret in a config, wherever it sits, and that it goes."""

from __future__ import annotations

from pathlib import Path

import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from carlaverse.redact import REDACTED, UNREADABLE, is_secret_name, redact, redact_yaml
from carlaverse.security.zenoh_entries import tls_entries, usrpwd_entries

PEM = "-----BEGIN PRIVATE KEY-----\nMIIEvQIBADANBg\n-----END PRIVATE KEY-----\n"


def test_secret_names_and_ordinary_names() -> None:
    for name in ("password", "connect_private_key", "api-key", "usrpwd", "token", "Secret"):
        assert is_secret_name(name), name
    for name in ("key", "keys", "key_exprs", "passes", "authority", "keep_alive", "per_key"):
        assert not is_secret_name(name), name


def test_a_roster_node_config_keeps_its_shape_and_loses_its_login() -> None:
    zenoh = {
        **tls_entries(Path("ca.pem"), None, None),
        **usrpwd_entries("drive-1", "pw-sekrit-123"),
        "transport/link/tls/connect_private_key": "/lab/certs/drive-1.key",
        "connect/timeout_ms": {"client": 1000},
    }
    config = {"node": {"node_id": "drive-1"}, "fabric": {"mode": "client", "zenoh": zenoh}}
    out = redact(config)["fabric"]["zenoh"]
    assert out["transport/auth/usrpwd/password"] == REDACTED
    assert out["transport/auth/usrpwd/user"] == REDACTED  # all of transport/auth
    assert out["transport/link/tls/connect_private_key"] == REDACTED
    assert out["transport/link/tls/root_ca_certificate"] == "ca.pem"  # public, kept
    assert out["transport/link/tls/enable_mtls"] is True  # settings are not secrets
    assert out["connect/timeout_ms"] == {"client": 1000}
    assert "pw-sekrit-123" not in str(redact(config))


def test_nested_auth_dictionaries_and_pem_anywhere() -> None:
    config = {
        "transport": {"auth": {"usrpwd": {"user": "u", "password": "p", "dictionary_file": "d"}}},
        "notes": [PEM, "plain"],
        "password": {"nested": {"deeper": "p2"}},
    }
    out = redact(config)
    assert out["transport"]["auth"]["usrpwd"] == dict.fromkeys(
        ("user", "password", "dictionary_file"), REDACTED
    )
    assert out["notes"] == [REDACTED, "plain"]
    assert out["password"] == {"nested": {"deeper": REDACTED}}


def test_yaml_without_secrets_is_returned_byte_for_byte() -> None:
    text = "node:\n  node_id: a   # a comment survives\nfabric: {mode: peer}\n"
    assert redact_yaml(text) is text
    once = redact_yaml("fabric:\n  zenoh:\n    transport/auth/usrpwd/password: hunter2\n")
    assert "hunter2" not in once and redact_yaml(once) == once  # idempotent


def test_unreadable_yaml_is_withheld_not_passed_on() -> None:
    assert redact_yaml("password: [unclosed") == UNREADABLE
    assert redact_yaml("[" * 10_000) == UNREADABLE  # nesting deeper than the parser goes


@settings(max_examples=200, deadline=None)
@given(
    path=st.lists(
        st.sampled_from(["fabric", "zenoh", "x", "transport", "auth", "usrpwd"]), max_size=5
    ),
    secret=st.text(alphabet="abcdefghijklmnop0123456789", min_size=12, max_size=20),
    name=st.sampled_from(["password", "connect_private_key", "secret", "token"]),
    flat=st.booleans(),
)
def test_a_secret_named_value_never_survives_at_any_depth(
    path: list[str], secret: str, name: str, flat: bool
) -> None:
    leaf: object = {name: secret}
    if flat:
        config = {"/".join([*path, name]): secret} if path else leaf
    else:
        config = leaf
        for segment in reversed(path):
            config = {segment: config}
    assert secret not in yaml.safe_dump(redact(config))
    assert secret not in redact_yaml(yaml.safe_dump(config))
