"""The door of a local web server: one pure ASGI middleware (no web framework imported)
that keeps the rule of `carlaverse.web_policy` (Host, Origin, Fetch Metadata, token), so a
refused request never reaches the app behind it.

Refusals are answered with their status and a one-line reason (a WebSocket before it is
accepted), counted by reason (`refused`) and never raised into the server; the 1st, 10th,
100th… of each are logged, never with a token. A page address with a good `?token=` is
answered with the cookie (HttpOnly, SameSite=Strict) and goes on to the same address without
the token, so it leaves the address bar: by a page that refreshes to it (a navigation the
server's own page makes is same-site, so the Strict cookie goes along); a server may answer
otherwise (`WebGuard._paired`: the launcher redirects where it can). Every HTTP response
gets `X-Frame-Options: DENY` and `Content-Security-Policy: frame-ancestors 'none'`
(clickjacking), `Referrer-Policy: no-referrer` (a token in an address never travels on) and
`X-Content-Type-Options: nosniff`.

    from carlaverse.web_policy import DoorPolicy, door_hosts, new_token
    policy = DoorPolicy(door_hosts("0.0.0.0", ["cabin-pc.lab"]), token=new_token(),
                        cookie="carlaverse-hmi-8080")
    app = WebGuard(starlette_app, policy)
"""

from __future__ import annotations

import html
import logging
from typing import Any
from urllib.parse import parse_qsl, quote, urlencode

from carlaverse.web_policy import (
    QUERY_KEY,
    REASONS,
    DoorPolicy,
    Refusal,
    Scope,
    judge,
    pairing_token,
    token_refusal,
    tokens_equal,
)

log = logging.getLogger(__name__)

Message = Any  # an ASGI message (a mapping)
Receive = Any  # async () -> Message
Send = Any  # async (Message) -> None
App = Any  # an ASGI application

FRAME_HEADERS = [
    (b"x-frame-options", b"DENY"),
    (b"content-security-policy", b"frame-ancestors 'none'"),
    (b"referrer-policy", b"no-referrer"),
    (b"x-content-type-options", b"nosniff"),
]


class WebGuard:
    """Pure ASGI middleware that keeps the door by a `DoorPolicy` (module docstring)."""

    def __init__(self, app: App, policy: DoorPolicy) -> None:
        self.app = app
        self.policy = policy
        self.refused: dict[str, int] = dict.fromkeys(REASONS, 0)

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)  # lifespan: the server's own start and stop
            return
        refusal = judge(self.policy, scope)
        shown = pairing_token(self.policy, scope) if refusal is None else None
        if shown is not None and not tokens_equal(shown, self.policy.token):
            refusal = token_refusal(self.policy)  # let in by its cookie; the URL's is wrong
        if refusal is not None:
            await self._refuse(scope, receive, send, refusal)
        elif shown is not None:
            await self._paired(scope, send, clean_url(scope))
        else:
            await self.app(scope, receive, with_frame_headers(send))

    async def _paired(self, scope: Scope, send: Send, clean: str) -> None:
        """Answer a good `?token=`: the cookie, and on to `clean` (the address without it)."""
        await send_reply(send, 200, pairing_page(clean), self.cookie_header())

    def cookie_header(self) -> tuple[bytes, bytes]:
        value = f"{self.policy.cookie}={self.policy.token}; Path=/; HttpOnly; SameSite=Strict"
        return b"set-cookie", value.encode()

    async def _refuse(self, scope: Scope, receive: Receive, send: Send, refusal: Refusal) -> None:
        self.refused[refusal.reason] += 1
        count = self.refused[refusal.reason]
        if str(count).strip("0") == "1":  # the 1st, 10th, 100th…: a flood stays quiet
            log.warning("%s refused request #%d for its %s: %s", self.policy.server, count,
                        refusal.reason, refusal.message)  # fmt: skip
        body = f"{self.policy.server}: {refusal.message}\n".encode()
        if scope["type"] == "http":
            await send_reply(send, refusal.status, body)
        else:
            await _deny_handshake(scope, receive, send, refusal.status, body)


# ------------------------------------------------------------ answers


def clean_url(scope: Scope) -> str:
    """The request's path and query without the token; never `//host` (another site)."""
    path = "/" + str(scope.get("path", "/")).lstrip("/")
    query = parse_qsl(scope.get("query_string", b"").decode("latin-1"))
    rest = urlencode([(k, v) for k, v in query if k != QUERY_KEY])
    return quote(path) + (f"?{rest}" if rest else "")


def pairing_page(url: str) -> bytes:
    """A page that goes on to `url`. A navigation from the server's own page, unlike a
    redirect of a link followed on another site, is same-site: the Strict cookie goes along."""
    quoted = html.escape(url, quote=True)
    return (f'<!doctype html><meta charset="utf-8"><meta http-equiv="refresh" '
            f'content="0;url={quoted}"><title>Paired</title>'
            f'<p>Paired. <a href="{quoted}">Continue</a></p>\n').encode()  # fmt: skip


def with_frame_headers(send: Send) -> Send:
    """`send` with the headers that forbid framing added to every HTTP response."""

    async def send_framed(message: Message) -> None:
        if message["type"] == "http.response.start":
            message = {**message, "headers": [*message.get("headers", []), *FRAME_HEADERS]}
        await send(message)

    return send_framed


async def send_reply(send: Send, status: int, body: bytes, *extra: tuple[bytes, bytes]) -> None:
    """A whole HTTP answer of the door's own, never cached, never to be framed."""
    kind = b"text/html; charset=utf-8" if status == 200 else b"text/plain; charset=utf-8"
    headers = [(b"content-type", kind), (b"content-length", str(len(body)).encode()),
               (b"cache-control", b"no-store"), *FRAME_HEADERS, *extra]  # fmt: skip
    await send({"type": "http.response.start", "status": status, "headers": headers})
    await send({"type": "http.response.body", "body": body})


async def _deny_handshake(
    scope: Scope, receive: Receive, send: Send, status: int, body: bytes
) -> None:
    """Refuse a WebSocket before accepting it: with `status` where the server can say it
    (the ASGI denial-response extension), else a close, which servers answer with 403."""
    if (await receive())["type"] != "websocket.connect":
        return  # the client left already
    if "websocket.http.response" not in scope.get("extensions", {}):
        await send({"type": "websocket.close", "code": 1008})
        return
    headers = [(b"content-type", b"text/plain; charset=utf-8"),
               (b"content-length", str(len(body)).encode())]  # fmt: skip
    await send({"type": "websocket.http.response.start", "status": status, "headers": headers})
    await send({"type": "websocket.http.response.body", "body": body})
