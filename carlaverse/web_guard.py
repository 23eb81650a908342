"""The door of a local web server: which names it answers to, which pages may open its
WebSockets, who must show a pairing token, and that no other site can frame it.

One pure ASGI middleware (no web framework imported), for any server of this project that
serves pages on a port. Each HTTP request and WebSocket handshake passes, in this order:

1. **Host** (DNS rebinding): a page whose name an attacker rebound to 127.0.0.1 reaches the
   port, but its browser names the page's own host in `Host`. Served are only the names in
   `DoorPolicy.hosts` (127.0.0.1, localhost, [::1], the bind address, names an operator
   adds) and the IP address the connection actually arrived on (an address names itself:
   rebinding needs a DNS name). Any port. Otherwise 403.
2. **Token**, when the policy has one: the `DoorPolicy.cookie` cookie, `?token=` or
   `Authorization: Bearer`, compared in constant time. Otherwise 401. An HTTP GET carrying
   a good `?token=` is answered with the cookie (HttpOnly, SameSite=Strict) and a page that
   goes on to the same address without the token, so it leaves the address bar.
3. **Origin**, on WebSocket handshakes (cross-site WebSocket hijacking): browsers send the
   page's origin on every handshake; it must be this server's own origin, `http(s)://` plus
   the request's Host. Otherwise 403. A handshake without Origin is a program rather than
   a browser, which could forge any Origin anyway, so Origin cannot stop it: it passes this
   step, and the token (when the policy has one) is what stops it.

Refusals are counted by reason (`refused`), never raised into the server. Every HTTP
response gets `X-Frame-Options: DENY` and `Content-Security-Policy: frame-ancestors 'none'`
(clickjacking), `Referrer-Policy: no-referrer` (a token in an address never travels on)
and `X-Content-Type-Options: nosniff`.

    policy = DoorPolicy(door_hosts("0.0.0.0", ["cabin-pc.lab"]), token=new_token(),
                        cookie="carlaverse-hmi-8080")
    app = WebGuard(starlette_app, policy)
"""

from __future__ import annotations

import hmac
import html
import ipaddress
import logging
import re
import secrets
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any
from urllib.parse import parse_qsl, urlencode

log = logging.getLogger(__name__)

Scope = dict[str, Any]
Message = dict[str, Any]
Receive = Any  # async () -> Message
Send = Any  # async (Message) -> None
App = Any  # an ASGI application

LOOPBACK_NAMES = ("127.0.0.1", "localhost", "::1")
TOKEN_BYTES = 32  # 256 bit: far beyond guessing over a network (issue 39 asks >= 128)
FRAME_HEADERS = [
    (b"x-frame-options", b"DENY"),
    (b"content-security-policy", b"frame-ancestors 'none'"),
    (b"referrer-policy", b"no-referrer"),
    (b"x-content-type-options", b"nosniff"),
]
_AUTHORITY = re.compile(r"(?:\[(?P<v6>[0-9A-Fa-f:.]+)\]|(?P<name>[A-Za-z0-9._-]+))"
                        r"(?::(?P<port>[0-9]{1,5}))?")  # fmt: skip
_ORIGIN = re.compile(r"(?P<scheme>https?)://(?P<authority>[^/?#]+)")
_NAME = re.compile(r"(?!-)[a-z0-9-]{1,63}(?<!-)(?:\.(?!-)[a-z0-9-]{1,63}(?<!-))*")
DEFAULT_PORTS = {"http": 80, "ws": 80, "https": 443, "wss": 443}


@dataclass(frozen=True)
class DoorPolicy:
    """Who a server answers: its host names, and the pairing token when one is asked for."""

    hosts: frozenset[str]  # normalised by `normal_host` (lower case, IPv6 without brackets)
    token: str | None = None  # None: no token asked (loopback, where Host/Origin suffice)
    cookie: str = "carlaverse-door"  # name of the cookie that keeps the token once paired
    host_hint: str = ""  # appended to a refused Host's message: how to add a name


def new_token() -> str:
    """A fresh pairing token: 256 random bits, URL-safe base64 (43 characters)."""
    return secrets.token_urlsafe(TOKEN_BYTES)


def normal_host(name: str) -> str:
    """A host name or address as the allow-list keeps it: lower case, no trailing dot,
    no IPv6 brackets, an address in its compressed form (an IPv4-mapped one as IPv4)."""
    name = name.lower().removesuffix(".")
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
    normal = normal_host(name)
    try:
        ipaddress.ip_address(normal)
    except ValueError:
        if not _NAME.fullmatch(normal) or len(normal) > 253:
            raise ValueError(f"{name!r} is not a host name or an IP address (no port, "
                             "no scheme: e.g. cabin-pc.lab or 192.168.1.20)") from None  # fmt: skip
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


class WebGuard:
    """Pure ASGI middleware that keeps the door by a `DoorPolicy` (module docstring)."""

    def __init__(self, app: App, policy: DoorPolicy) -> None:
        self.app = app
        self.policy = policy
        self.refused: Counter[str] = Counter()  # by reason: host, token, origin

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        kind = scope["type"]
        if kind not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        status, reason, message = self._judge(scope)
        if status:
            self._count(reason, message)
            if kind == "http":
                await _http_reply(send, status, message.encode())
            else:
                await _deny_handshake(scope, receive, send, status, message)
        elif kind == "websocket":
            await self.app(scope, receive, send)
        elif self._pairs(scope):
            await _http_reply(send, 200, _pairing_page(scope), self._cookie_header())
        else:
            await self.app(scope, receive, with_frame_headers(send))

    # ------------------------------------------------------------ the checks

    def _judge(self, scope: Scope) -> tuple[int, str, str]:
        """(0, "", "") to let the request in, else (status, reason, one-line message)."""
        headers = _headers(scope)
        host = split_authority(headers.get("host", ""))
        if host is None or not self._known_host(host[0], scope):
            shown = headers.get("host", "")[:100]
            hint = self.policy.host_hint
            return 403, "host", f"403: Host {shown!r} is not a name of this server{hint}"
        if self.policy.token is not None and not self._holds_token(scope, headers):
            return 401, "token", ("401: this server asks for its pairing token: open the URL "
                                  "with ?token= printed on its terminal")  # fmt: skip
        origin = headers.get("origin")
        if scope["type"] == "websocket" and origin is not None and not _same_origin(origin, host):
            return 403, "origin", f"403: a page from {origin[:100]!r} may not open this WebSocket"
        return 0, "", ""

    def _known_host(self, host: str, scope: Scope) -> bool:
        if host in self.policy.hosts:
            return True
        server = scope.get("server") or ("", None)
        return host == normal_host(str(server[0])) and _is_address(host)

    def _holds_token(self, scope: Scope, headers: dict[str, str]) -> bool:
        expected = self.policy.token
        assert expected is not None
        shown = [
            _cookies(headers.get("cookie", "")).get(self.policy.cookie),
            _query(scope).get("token"),
            headers.get("authorization", "").removeprefix("Bearer ").strip() or None,
        ]
        return any(_equal(s, expected) for s in shown if s)

    def _pairs(self, scope: Scope) -> bool:
        """A GET that brings a good token in its address: pair it (cookie, clean address)."""
        token, expected = _query(scope).get("token"), self.policy.token
        if token is None or expected is None or scope.get("method") != "GET":
            return False
        return _equal(token, expected)

    def _cookie_header(self) -> tuple[bytes, bytes]:
        value = f"{self.policy.cookie}={self.policy.token}; Path=/; HttpOnly; SameSite=Strict"
        return b"set-cookie", value.encode()

    def _count(self, reason: str, message: str) -> None:
        self.refused[reason] += 1
        if self.refused[reason] == 1:  # said once; the count carries the rest
            log.warning("refused a request: %s", message)


# ------------------------------------------------------------ helpers


def _headers(scope: Scope) -> dict[str, str]:
    """Request headers, lower-case names; a repeated Host or Origin counts as missing."""
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


def _query(scope: Scope) -> dict[str, str]:
    return dict(parse_qsl(scope.get("query_string", b"").decode("latin-1")))


def _equal(shown: str, expected: str) -> bool:
    return hmac.compare_digest(shown.encode("utf-8", "surrogateescape"), expected.encode())


def _is_address(host: str) -> bool:
    try:
        ipaddress.ip_address(host)
    except ValueError:
        return False
    return True


def _same_origin(origin: str, host: tuple[str, int | None]) -> bool:
    """Whether `Origin` names the server the request reached (scheme http(s), same host
    and port as its Host header; a missing port is the scheme's default)."""
    found = _ORIGIN.fullmatch(origin)
    if found is None:
        return False  # "null" (a sandboxed or file page) and anything malformed
    named = split_authority(found["authority"])
    if named is None:
        return False
    default = DEFAULT_PORTS[found["scheme"]]
    return named[0] == host[0] and (named[1] or default) == (host[1] or default)


def _pairing_page(scope: Scope) -> bytes:
    """A page that goes on to the address without its token (the cookie now holds it).
    A navigation from the server's own page, unlike a redirect of a link followed on
    another site, is same-site, so the SameSite=Strict cookie goes with it."""
    rest = [(k, v) for k, v in parse_qsl(scope.get("query_string", b"").decode("latin-1"))
            if k != "token"]  # fmt: skip
    path = "/" + str(scope.get("path", "/")).lstrip("/")  # never `//host`: another site
    target = html.escape(path + (f"?{urlencode(rest)}" if rest else ""))
    return (f"<!doctype html><meta charset='utf-8'><meta http-equiv='refresh' "
            f"content='0;url={target}'><title>Paired</title>"
            f"<p>Paired. <a href='{target}'>Continue</a></p>").encode()  # fmt: skip


def with_frame_headers(send: Send) -> Send:
    """`send` with the headers that forbid framing added to every HTTP response."""

    async def send_framed(message: Message) -> None:
        if message["type"] == "http.response.start":
            message = {**message, "headers": [*message.get("headers", []), *FRAME_HEADERS]}
        await send(message)

    return send_framed


async def _http_reply(send: Send, status: int, body: bytes, *extra: tuple[bytes, bytes]) -> None:
    kind = b"text/html; charset=utf-8" if status == 200 else b"text/plain; charset=utf-8"
    headers = [(b"content-type", kind), (b"content-length", str(len(body)).encode()),
               (b"cache-control", b"no-store"), *FRAME_HEADERS, *extra]  # fmt: skip
    await send({"type": "http.response.start", "status": status, "headers": headers})
    await send({"type": "http.response.body", "body": body})


async def _deny_handshake(
    scope: Scope, receive: Receive, send: Send, status: int, message: str
) -> None:
    """Refuse a WebSocket before accepting it: with `status` where the server can say it
    (the ASGI denial-response extension), else a close, which servers answer with 403."""
    if (await receive())["type"] != "websocket.connect":
        return  # the client left already
    if "websocket.http.response" not in scope.get("extensions", {}):
        await send({"type": "websocket.close", "code": 1008})
        return
    body = message.encode()
    headers = [(b"content-type", b"text/plain; charset=utf-8"),
               (b"content-length", str(len(body)).encode())]  # fmt: skip
    await send({"type": "websocket.http.response.start", "status": status, "headers": headers})
    await send({"type": "websocket.http.response.body", "body": body})
