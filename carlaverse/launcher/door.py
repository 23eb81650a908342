"""The launcher's door: a request is let in only with the launch token, from an allowed Host,
and from the launcher's own Origin; everything else is refused before the web app sees it.

A plain ASGI middleware (no web framework imported), so a refused request never reaches
NiceGUI: no page built, no client session kept, no event-loop time beyond reading headers.
The rules are Jupyter's:

- **Host** must name this machine as its operator reaches it (127.0.0.1, localhost, [::1], the
  bind address, names given with `--allow-host`), with or without a port. A page on another
  site that DNS rebinding points at 127.0.0.1 still carries its own name in Host: 403.
- **Origin**, when a browser sends one, must be the launcher's own (the scheme `http` and the
  very Host the request names): a page elsewhere can neither open the socket.io channel nor
  post. 403 otherwise. Scripts send no Origin; the token is what they show.
- **Fetch Metadata**: a request another page makes (an `<img>`, a frame, a script; browsers
  say so in `Sec-Fetch-Site`/`Mode`/`Dest`) is refused unless it comes from the launcher's
  own page: another port on 127.0.0.1 is the same *site*, so the Strict cookie goes along, and
  an `<img>` loop there would otherwise make the launcher build page after page. Top-level
  navigations pass (a link, the file:// page the browser is opened on).
- **Token** (256 bit, fresh each launch): an HttpOnly SameSite=Strict cookie, an
  `Authorization: Bearer` header, or `?token=`. A page URL with `?token=` sets the cookie and
  redirects to the same URL without it, so the token leaves the address bar: a 303, or, when
  the browser came from another site (the file:// page the launcher opens the browser on), a
  page that refreshes to it — a Strict cookie is not sent along a redirect chain that another
  site began, but is on a navigation the launcher's own page makes. 401 otherwise.
- **No framing**: every answer, refusals too, carries `X-Frame-Options: DENY` and
  `Content-Security-Policy: frame-ancestors 'none'` (clickjacking), and `Referrer-Policy:
  no-referrer`.
"""

from __future__ import annotations

import hmac
import html
import ipaddress
import logging
import urllib.parse
from collections.abc import Awaitable, Callable, Iterable, MutableMapping
from typing import Any

from carlaverse.web_guard import FRAME_HEADERS, with_frame_headers

Scope = MutableMapping[str, Any]
Message = MutableMapping[str, Any]
Receive = Callable[[], Awaitable[Message]]
Send = Callable[[Message], Awaitable[None]]
ASGIApp = Callable[[Scope, Receive, Send], Awaitable[None]]

log = logging.getLogger(__name__)

LOOPBACK_NAMES = ("127.0.0.1", "localhost", "::1")
QUERY_KEY = "token"
# Paths the web app's own scripts fetch (socket.io polling, static files): a `?token=` there is
# a script's credential, answered in place, never redirected.
APP_PATHS = ("/_nicegui",)
WS_POLICY_VIOLATION = 1008  # RFC 6455 close code; before accept, servers answer HTTP 403


def cookie_name(port: int) -> str:
    """Cookies ignore ports: two launchers on one host each need a name of their own."""
    return f"carlaverse-launcher-{port}"


def host_name(header: str) -> str | None:
    """The name a Host header carries, lower case, without its port; None when malformed.

    `127.0.0.1:8470` → `127.0.0.1`, `[::1]:8470` → `::1`, `LocalHost` → `localhost`.
    """
    if header.startswith("["):
        name, bracket, rest = header[1:].partition("]")
        if not bracket or (rest and not _port_suffix(rest)):
            return None
        return name.lower()
    name, colon, port = header.partition(":")
    if colon and not _port_suffix(colon + port):
        return None
    return name.lower() or None


def _port_suffix(text: str) -> bool:
    return text.startswith(":") and text[1:].isdigit() and len(text) <= 6


class HostPolicy:
    """The names a Host header may carry: this machine's, the bind address and those allowed.

    Bound to every interface (0.0.0.0 or ::), any IP literal is accepted too: DNS rebinding needs
    a name, and a literal address is what a colleague on the lab network types.
    """

    def __init__(self, bind: str, extra: Iterable[str] = ()) -> None:
        self.names = {n.lower().strip("[]") for n in (*LOOPBACK_NAMES, bind, *extra)}
        self.any_address = bind in ("0.0.0.0", "::", "")

    def allows(self, header: str) -> bool:
        name = host_name(header)
        if name is None:
            return False
        return name in self.names or (self.any_address and _is_ip(name))


def _is_ip(name: str) -> bool:
    try:
        ipaddress.ip_address(name)
    except ValueError:
        return False
    return True


def same_origin(origin: str, host: str) -> bool:
    """Whether an Origin header names the launcher itself as the request reached it."""
    parts = urllib.parse.urlsplit(origin)
    return (
        parts.scheme == "http"
        and parts.netloc.lower() == host.lower()
        and not parts.path
        and not parts.query
    )


class Door:
    """ASGI middleware: Host, Origin and token checked on every HTTP request and WebSocket."""

    def __init__(self, app: ASGIApp, token: str, hosts: HostPolicy, cookie: str) -> None:
        self.app = app
        self._token = token.encode()
        self.hosts = hosts
        self.cookie = cookie
        self.refused = {"host": 0, "origin": 0, "site": 0, "token": 0}  # for the log, tests

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)  # lifespan: the server's own start and stop
            return
        refusal = self._refusal(scope)
        if refusal is not None:
            self._count(refusal[0], refusal[2])
            await _refuse(scope, send, refusal[1], refusal[2])
            return
        in_query = _query_token(scope)
        if in_query is not None and scope["type"] == "http" and _is_page(scope):
            await self._set_cookie_and_redirect(scope, send, in_query)
            return
        await self.app(scope, receive, with_frame_headers(send))

    def _refusal(self, scope: Scope) -> tuple[str, int, str] | None:
        """(what, HTTP status, reason) of a refusal, or None to let the request in."""
        headers = _headers(scope)
        host = headers.get("host", "")
        if not self.hosts.allows(host):
            return "host", 403, f"Host {host!r} is not this launcher's; see --allow-host"
        origin = headers.get("origin")
        if origin is not None and not same_origin(origin, host):
            return "origin", 403, "requests from another site are refused"
        if not _own_or_navigation(headers):
            return "site", 403, "requests another page embeds are refused"
        shown = [
            _cookie(headers.get("cookie", ""), self.cookie),
            _bearer(headers.get("authorization", "")),
            _query_token(scope),
        ]
        if not any(s is not None and self._matches(s) for s in shown):
            return "token", 401, NEEDS_TOKEN
        return None

    def _count(self, what: str, reason: str) -> None:
        """Count a refusal; log the 1st, 10th, 100th… of each kind (a flood stays quiet)."""
        self.refused[what] += 1
        count = self.refused[what]
        if str(count).strip("0") == "1":
            log.warning("refused request #%d for its %s: %s", count, what, reason)

    def _matches(self, candidate: str) -> bool:
        return hmac.compare_digest(candidate.encode(), self._token)

    async def _set_cookie_and_redirect(self, scope: Scope, send: Send, token: str) -> None:
        if not self._matches(token):  # let in by its cookie, but the URL's token is wrong
            self._count("token", NEEDS_TOKEN)
            await _refuse(scope, send, 401, NEEDS_TOKEN)
            return
        cookie = f"{self.cookie}={token}; Path=/; HttpOnly; SameSite=Strict"
        clean = _clean_url(scope)
        headers = [(b"set-cookie", cookie.encode()), (b"cache-control", b"no-store")]
        if _headers(scope).get("sec-fetch-site", "none") in ("none", "same-origin"):
            status, body = 303, b""
            headers.append((b"location", clean.encode()))
        else:
            status, body = 200, _refresh_page(clean)
            headers.append((b"content-type", b"text/html; charset=utf-8"))
        headers += [(b"content-length", str(len(body)).encode()), *FRAME_HEADERS]
        await send({"type": "http.response.start", "status": status, "headers": headers})
        await send({"type": "http.response.body", "body": body})


NEEDS_TOKEN = (
    "this launcher needs its launch token: open the URL it printed at start, or send the token "
    "from its token file (Authorization: Bearer TOKEN)"
)


def _own_or_navigation(headers: dict[str, str]) -> bool:
    """Fetch Metadata's resource isolation: the launcher's own requests, a top-level
    navigation, or a client that sends no metadata (a script; it shows the token)."""
    site = headers.get("sec-fetch-site")
    if site in (None, "same-origin", "none"):
        return True
    navigation = headers.get("sec-fetch-mode") == "navigate"
    return navigation and headers.get("sec-fetch-dest", "document") == "document"


def _query_token(scope: Scope) -> str | None:
    query = urllib.parse.parse_qs(scope.get("query_string", b"").decode("latin-1"))
    values = query.get(QUERY_KEY)
    return values[0] if values else None


def _headers(scope: Scope) -> dict[str, str]:
    """Header names lower case, values as latin-1 text; a repeated header keeps its first."""
    found: dict[str, str] = {}
    for name, value in scope.get("headers", []):
        found.setdefault(name.decode("latin-1").lower(), value.decode("latin-1"))
    return found


def _cookie(header: str, name: str) -> str | None:
    for pair in header.split(";"):
        key, eq, value = pair.strip().partition("=")
        if eq and key == name:
            return value
    return None


def _bearer(header: str) -> str | None:
    scheme, _, value = header.partition(" ")
    return value.strip() if scheme.lower() == "bearer" and value.strip() else None


def _is_page(scope: Scope) -> bool:
    path = scope.get("path", "/")
    return scope.get("method") in ("GET", "HEAD") and not path.startswith(APP_PATHS)


def _clean_url(scope: Scope) -> str:
    """The request's path and query without the token; never `//host` (another site)."""
    path = "/" + scope.get("path", "/").lstrip("/")
    query = urllib.parse.parse_qsl(scope.get("query_string", b"").decode("latin-1"))
    rest = urllib.parse.urlencode([(k, v) for k, v in query if k != QUERY_KEY])
    return urllib.parse.quote(path) + (f"?{rest}" if rest else "")


def _refresh_page(url: str) -> bytes:
    quoted = html.escape(url, quote=True)
    return (
        f'<!doctype html><meta charset="utf-8"><meta http-equiv="refresh" content="0;url={quoted}">'
        f'<title>CARLAverse launcher</title><a href="{quoted}">open the launcher</a>\n'
    ).encode()


async def _refuse(scope: Scope, send: Send, status: int, reason: str) -> None:
    if scope["type"] == "websocket":
        await send({"type": "websocket.close", "code": WS_POLICY_VIOLATION, "reason": reason})
        return
    body = f"carlaverse launcher: {reason}\n".encode()
    await send(
        {
            "type": "http.response.start",
            "status": status,
            "headers": [
                (b"content-type", b"text/plain; charset=utf-8"),
                (b"content-length", str(len(body)).encode()),
                (b"cache-control", b"no-store"),
                *FRAME_HEADERS,
            ],
        }
    )
    await send({"type": "http.response.body", "body": body})
