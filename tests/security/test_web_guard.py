"""carlaverse.web_policy's parsers: what a Host, an Origin and an operator's name may be.

Expected values come from the standards: Host is `host [ ":" port ]` with an IPv6 address in
brackets (RFC 9110 §7.2, RFC 3986 §3.2.2), names are case-insensitive (RFC 4343), an
Origin is `scheme "://" host [ ":" port ]` whose missing port is the scheme's default
(RFC 6454 §4, §7), and `null` is the origin of sandboxed and file pages. The project's web
servers speak plain HTTP, so an `https` origin is never their own page's; and `localhost.`,
to a browser another origin than `localhost` (RFC 6454 compares hosts as strings), is none
of their pages' names.
"""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from carlaverse.web_policy import (
    check_host_name,
    door_hosts,
    is_loopback,
    new_token,
    same_origin,
    split_authority,
)


@pytest.mark.parametrize("value, expected", [
    ("127.0.0.1:8080", ("127.0.0.1", 8080)),
    ("LocalHost", ("localhost", None)),
    ("localhost.:80", ("localhost.", 80)),  # another origin to a browser: not its pages'
    ("[::1]:8080", ("::1", 8080)),
    ("[0:0:0:0:0:0:0:1]", ("::1", None)),  # one address, one spelling
    ("[::ffff:127.0.0.1]:1", ("127.0.0.1", 1)),  # IPv4-mapped: the IPv4 address
])  # fmt: skip
def test_a_host_header_is_split_and_normalised(value: str, expected: tuple[str, int]) -> None:
    assert split_authority(value) == expected


@pytest.mark.parametrize("value", [
    "", "localhost\n", "localhost\x00", "local host", "localhost:99999", "localhost:",
    "::1", "[::1", "user@localhost", "localhost/x", "lоcalhost",  # Cyrillic о
    "127.0.0.1:80:80", "http://localhost",
])  # fmt: skip
def test_what_is_not_a_host_header_is_refused(value: str) -> None:
    assert split_authority(value) is None


@given(st.text(max_size=60))
def test_any_text_parses_or_is_refused_never_raises(value: str) -> None:
    split_authority(value)


@pytest.mark.parametrize("origin, host, same", [
    ("http://127.0.0.1:8080", ("127.0.0.1", 8080), True),
    ("http://LOCALHOST:8080", ("localhost", 8080), True),
    ("http://localhost", ("localhost", 80), True),  # http's default port
    ("https://localhost", ("localhost", None), False),  # these servers speak plain HTTP
    ("http://localhost", ("localhost", 443), False),
    ("http://127.0.0.1:8081", ("127.0.0.1", 8080), False),  # another local origin
    ("http://localhost:8080", ("127.0.0.1", 8080), False),  # another name: another origin
    ("http://evil.example", ("127.0.0.1", 8080), False),
    ("null", ("127.0.0.1", 8080), False),
    ("file://", ("127.0.0.1", 8080), False),
    ("ws://127.0.0.1:8080", ("127.0.0.1", 8080), False),  # never a page's origin
    ("http://127.0.0.1:8080/", ("127.0.0.1", 8080), False),  # origins have no path
    ("http://127.0.0.1:8080\n", ("127.0.0.1", 8080), False),
])  # fmt: skip
def test_same_origin(origin: str, host: tuple[str, int | None], same: bool) -> None:
    assert same_origin(origin, host) is same


@pytest.mark.parametrize("name", ["cabin-pc.lab", "CABIN-PC", "192.168.1.20", "fe80::1"])
def test_an_operators_host_name(name: str) -> None:
    assert check_host_name(name) == name.lower()


@pytest.mark.parametrize("name", [
    "cabin-pc.lab:8080", "http://cabin-pc.lab", "a..b", "-a.lab", "a-.lab", "cabin pc",
    "cabin-pc\n", "", "*.lab", "x" * 64,
])  # fmt: skip
def test_what_is_not_a_host_name_is_one_clear_error(name: str) -> None:
    with pytest.raises(ValueError, match="is not a host name or an IP address"):
        check_host_name(name)


def test_loopback_is_decided_by_address() -> None:
    assert is_loopback("127.0.0.2") and is_loopback("::1") and is_loopback("::ffff:127.0.0.1")
    assert not is_loopback("0.0.0.0") and not is_loopback("::") and not is_loopback("10.0.0.1")
    assert not is_loopback("localhost")  # a name: the server asks its socket instead


def test_the_door_answers_to_loopback_the_bind_address_and_the_operators_names() -> None:
    assert door_hosts("0.0.0.0", ["Cabin-PC.lab"]) == {
        "127.0.0.1", "localhost", "::1", "0.0.0.0", "cabin-pc.lab",
    }  # fmt: skip


def test_tokens_are_fresh_and_at_least_128_bit() -> None:
    tokens = {new_token() for _ in range(100)}
    assert len(tokens) == 100
    assert all(len(t) * 6 >= 128 and t.isascii() for t in tokens)  # base64url: 6 bits/char
