"""The rule of this project's local web servers (the HMI, the launcher), written once:
which names a server answers to, which pages may reach it, and who must show its token.
`carlaverse.web_guard` keeps a server's door by it; `judge` is the whole decision.

Each HTTP request and WebSocket handshake passes, in this order (the first step it fails
answers it):

1. **Host** (DNS rebinding): a page whose name an attacker rebound to 127.0.0.1 reaches the
   port, but its browser names the page's own host in `Host`. Served are only the names in
   `DoorPolicy.hosts` (127.0.0.1, localhost, [::1], the bind address, names an operator
   adds) and the IP address the connection actually arrived on (an address names itself:
   rebinding needs a DNS name), with or without a port. A malformed or repeated Host names
   none of them. Otherwise 403.
2. **Origin** (cross-site requests, WebSocket hijacking): browsers send the page's origin on
   every handshake and on cross-origin requests; it must be this server's own, `http://` plus
   the request's Host (a missing port is http's: RFC 6454). Otherwise 403. A client without
   Origin is a program rather than a browser, which could forge any Origin anyway: the token
   (when the policy has one) is what stops it.
3. **Fetch Metadata** (what another page embeds): a request a browser marks in
   `Sec-Fetch-Site` as made by another page (an `<img>`, a frame, a script) is refused unless
   it comes from the server's own origin: another port on 127.0.0.1 is the same *site*, so a
   Strict cookie goes along with it. Top-level navigations pass (a link, a QR code, a file://
   page), and so does a client that sends no metadata. Otherwise 403.
4. **Token**, when the policy has one: the `DoorPolicy.cookie` cookie, `Authorization: Bearer`
   or `?token=`, compared in constant time. Otherwise 401.

A GET or HEAD whose address carries `?token=` (outside `DoorPolicy.script_paths`, where the
app's scripts send it) pairs (`pairing_token`): a wrong one is 401 whatever cookie came along.
"""

from __future__ import annotations

import hmac
import ipaddress
import re
import secrets
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, NamedTuple
from urllib.parse import parse_qsl

Scope = Any  # an ASGI connection scope (a mapping)

LOOPBACK_NAMES = ("127.0.0.1", "localhost", "::1")
TOKEN_BYTES = 32  # 256 bit: far beyond guessing over a network (issue 39 asks >= 128)
QUERY_KEY = "token"
REASONS = ("host", "origin", "site", "token")  # what a refusal is counted by
_AUTHORITY = re.compile(r"(?:\[(?P<v6>[0-9A-Fa-f:.]+)\]|(?P<name>[A-Za-z0-9._-]+))"
                        r"(?::(?P<port>[0-9]{1,5}))?")  # fmt: skip
_ORIGIN = re.compile(r"http://(?P<authority>[^/?#]+)")  # these servers speak plain HTTP
_NAME = re.compile(r"(?!-)[a-z0-9-]{1,63}(?<!-)(?:\.(?!-)[a-z0-9-]{1,63}(?<!-))*")
HTTP_PORT = 80


@dataclass(frozen=True)
class DoorPolicy:
    """Who a server answers: its host names, and the token when one is asked for."""

    hosts: frozenset[str]  # normalised by `normal_host` (lower case, IPv6 without brackets)
    token: str | None = None  # None: no token asked (loopback, where Host/Origin suffice)
    cookie: str = "carlaverse-door"  # name of the cookie that keeps the token once paired
    host_hint: str = ""  # appended to a refused Host's message: how to add a name
    token_hint: str = "open the URL with ?token= printed on its terminal"  # how to get in
    server: str = "carlaverse"  # names the server in its refusals and log lines
    script_paths: tuple[str, ...] = ()  # path prefixes whose `?token=` is a script's, not paired


class Refusal(NamedTuple):
    status: int  # the HTTP status it is answered with
    reason: str  # one of REASONS
    message: str  # one line, never holding a token


def new_token() -> str:
    """A fresh token: 256 random bits, URL-safe base64 (43 characters)."""
    return secrets.token_urlsafe(TOKEN_BYTES)


def normal_host(name: str) -> str:
    """A host name or address as the allow-list keeps it: lower case, no IPv6 brackets, an
    address in its compressed form (an IPv4-mapped one as IPv4). A trailing dot is kept:
    to a browser `localhost.` is another origin, and none of this server's pages."""
    name = name.lower()
    if name.startswith("[") and name.endswith("]"):
        name = name[1:-1]
    try:
        address = ipaddress.ip_address(name)
    except ValueError:
        return name
    mapped = getattr(address, "ipv4_mapped", None)
    return str(mapped or address)


def check_host_name(name: str) -> str:
    """`name` normalised if it is a DNS name or an IP address (no port); else ValueError."""
    normal = normal_host(name).removesuffix(".")  # an operator's `cabin-pc.lab.` is that name
    if not _is_address(normal) and (not _NAME.fullmatch(normal) or len(normal) > 253):
        raise ValueError(f"{name!r} is not a host name or an IP address (no port, "
                         "no scheme: e.g. cabin-pc.lab or 192.168.1.20)")  # fmt: skip
    return normal


def is_loopback(address: str) -> bool:
    """Whether `address` (an IP literal) is a loopback address; a name is not."""
    try:
        return ipaddress.ip_address(normal_host(address)).is_loopback
    except ValueError:
        return False


def door_hosts(bind: str, extra: Iterable[str] = ()) -> frozenset[str]:
    """The names a server bound to `bind` answers to: loopback, `bind` itself, `extra`."""
    return frozenset(normal_host(n) for n in (*LOOPBACK_NAMES, bind, *extra) if n)


def split_authority(value: str) -> tuple[str, int | None] | None:
    """`host[:port]` as (normalised host, port or None); None when it is not one."""
    found = _AUTHORITY.fullmatch(value)
    if found is None:
        return None
    port = int(found["port"]) if found["port"] else None
    if port is not None and port > 65535:
        return None
    return normal_host(found["v6"] or found["name"]), port


def same_origin(origin: str, host: tuple[str, int | None]) -> bool:
    """Whether `Origin` names the server the request reached: `http://`, the same host and
    port as its Host header (a missing port is http's default)."""
    found = _ORIGIN.fullmatch(origin)
    if found is None:
        return False  # "null" (a sandboxed or file page), https, anything malformed
    named = split_authority(found["authority"])
    if named is None:
        return False
    return named[0] == host[0] and (named[1] or HTTP_PORT) == (host[1] or HTTP_PORT)


def embedded_elsewhere(headers: dict[str, str]) -> bool:
    """Fetch Metadata's resource isolation: whether another page made this request (not
    the server's own page, not a top-level navigation, not a client without metadata)."""
    site = headers.get("sec-fetch-site")
    if site in (None, "same-origin", "none"):
        return False
    navigation = headers.get("sec-fetch-mode") == "navigate"
    return not (navigation and headers.get("sec-fetch-dest", "document") == "document")


def judge(policy: DoorPolicy, scope: Scope) -> Refusal | None:
    """Why `policy` refuses this request or handshake, or None to let it in (steps 1-4)."""
    headers = request_headers(scope)
    host = split_authority(headers.get("host", ""))
    if host is None or not _known_host(policy, host[0], scope):
        shown = headers.get("host", "")[:100]
        message = f"Host {shown!r} is not a name of this server{policy.host_hint}"
        return Refusal(403, "host", message)
    origin = headers.get("origin")
    if origin is not None and not same_origin(origin, host):
        return Refusal(403, "origin", f"a page from {origin[:100]!r} may not reach this server")
    if embedded_elsewhere(headers):
        return Refusal(403, "site", "a request another page embeds is refused")
    if policy.token is not None and not _holds_token(policy, scope, headers):
        return token_refusal(policy)
    return None


def token_refusal(policy: DoorPolicy) -> Refusal:
    """The refusal of a request that does not show the policy's token."""
    return Refusal(401, "token", f"this server asks for its token: {policy.token_hint}")


def pairing_token(policy: DoorPolicy, scope: Scope) -> str | None:
    """The `?token=` of a page request that pairs (module docstring), else None."""
    page = scope["type"] == "http" and scope.get("method") in ("GET", "HEAD")
    scripts = str(scope.get("path", "/")).startswith(policy.script_paths)
    return _query_token(scope) if policy.token is not None and page and not scripts else None


def _known_host(policy: DoorPolicy, host: str, scope: Scope) -> bool:
    if host in policy.hosts:
        return True
    server = scope.get("server") or ("", None)
    return host == normal_host(str(server[0])) and _is_address(host)


def _holds_token(policy: DoorPolicy, scope: Scope, headers: dict[str, str]) -> bool:
    shown = [
        _cookies(headers.get("cookie", "")).get(policy.cookie),
        _bearer(headers.get("authorization", "")),
        _query_token(scope),
    ]
    return any(tokens_equal(s, policy.token) for s in shown if s)


def tokens_equal(shown: str, expected: str | None) -> bool:
    """Constant-time comparison, so the time taken tells nothing of the token."""
    if expected is None:
        return False
    return hmac.compare_digest(shown.encode("utf-8", "surrogateescape"), expected.encode())


# ------------------------------------------------------------ parsing


def request_headers(scope: Scope) -> dict[str, str]:
    """Request headers, lower-case names; a repeated Host or Origin counts as malformed."""
    found: dict[str, str] = {}
    repeated: set[str] = set()
    for raw_name, raw_value in scope.get("headers", []):
        name = raw_name.decode("latin-1").lower()
        if name in found and name in ("host", "origin"):
            repeated.add(name)
        found[name] = raw_value.decode("latin-1")
    for name in repeated:
        found[name] = "\x00repeated"  # matches no allowed host or origin
    return found


def _cookies(header: str) -> dict[str, str]:
    pairs = (part.strip().partition("=") for part in header.split(";"))
    return {name: value for name, sep, value in pairs if sep}


def _bearer(header: str) -> str | None:
    scheme, _, value = header.partition(" ")
    return value.strip() if scheme.lower() == "bearer" and value.strip() else None


def _query_token(scope: Scope) -> str | None:
    query = parse_qsl(scope.get("query_string", b"").decode("latin-1"))
    return next((value for key, value in query if key == QUERY_KEY), None)


def _is_address(host: str) -> bool:
    try:
        ipaddress.ip_address(host)
    except ValueError:
        return False
    return True
