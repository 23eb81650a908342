"""The launcher's door, driven as ASGI in-process in front of an app that counts its calls:
a refused request never reaches the app behind it (so NiceGUI builds no page for it).

The rules are Jupyter's, stated in issue 39: Host must name this machine (or a name the
operator allowed), with or without a port; an Origin, when present, must be the launcher's own;
the token must be shown (cookie, Bearer header or query); `?token=` on a page becomes an
HttpOnly SameSite=Strict cookie and a redirect to the URL without it; every answer forbids
framing.
"""

from __future__ import annotations

import asyncio
import re
from typing import Any

import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from carlaverse.launcher.door import Door, HostPolicy, cookie_name
from carlaverse.web_policy import new_token

TOKEN = new_token()
PORT = 8470
COOKIE = cookie_name(PORT)


class CountingApp:
    """Stands for NiceGUI: answers 200 and counts the requests that reached it."""

    def __init__(self) -> None:
        self.calls = 0

    async def __call__(self, scope: Any, receive: Any, send: Any) -> None:
        self.calls += 1
        if scope["type"] == "websocket":
            await send({"type": "websocket.accept"})
            return
        await send({"type": "http.response.start", "status": 200, "headers": []})
        await send({"type": "http.response.body", "body": b"the page"})


def call(
    door: Door,
    path: str = "/",
    query: str = "",
    headers: dict[str, str] | None = None,
    kind: str = "http",
    server: tuple[str, int] | None = None,
) -> tuple[int, dict[str, str], bytes]:
    """(status, headers, body) of one request; a WebSocket answers 101 or its close code.
    `server`: the address the connection arrived on (ASGI's scope["server"])."""
    sent: list[dict[str, Any]] = []
    scope = {
        "type": kind,
        "method": "GET",
        "path": path,
        "query_string": query.encode(),
        "headers": [(k.lower().encode(), v.encode()) for k, v in (headers or {}).items()],
        "server": server,
    }

    async def receive() -> dict[str, Any]:
        if kind == "websocket":
            return {"type": "websocket.connect"}  # a handshake's first message (ASGI)
        return {"type": "http.request", "body": b""}

    async def send(message: dict[str, Any]) -> None:
        sent.append(message)

    asyncio.run(door(scope, receive, send))
    if kind == "websocket":
        return (101 if sent[0]["type"] == "websocket.accept" else sent[0]["code"]), {}, b""
    start = sent[0]
    answer = {k.decode(): v.decode() for k, v in start["headers"]}
    return start["status"], answer, b"".join(m.get("body", b"") for m in sent[1:])


@pytest.fixture
def app() -> CountingApp:
    return CountingApp()


@pytest.fixture
def door(app: CountingApp) -> Door:
    return Door(app, TOKEN, HostPolicy("127.0.0.1", ["lab-pc.local"]), COOKIE)


LOCAL = {"host": f"127.0.0.1:{PORT}"}
WITH_TOKEN = {**LOCAL, "authorization": f"Bearer {TOKEN}"}


def test_the_token_is_long_and_fresh() -> None:
    # token_urlsafe(n) encodes n random bytes in ceil(4n/3) characters: >= 128 bit needs n >= 16
    tokens = {new_token() for _ in range(100)}
    assert len(tokens) == 100 and all(len(t) >= 22 for t in tokens)


def test_without_the_token_nothing_reaches_the_app(door: Door, app: CountingApp) -> None:
    for headers in (LOCAL, {**LOCAL, "cookie": f"{COOKIE}=wrong"},
                    {**LOCAL, "authorization": "Bearer wrong"},
                    {**LOCAL, "cookie": f"carlaverse-launcher-9999={TOKEN}"}):  # fmt: skip
        status, answer, _ = call(door, headers=headers)
        assert status == 401 and answer["x-frame-options"] == "DENY"
    assert call(door, "/", "token=wrong", LOCAL)[0] == 401
    assert call(door, "/_nicegui_ws/socket.io/", "EIO=4&transport=polling", LOCAL)[0] == 401
    assert call(door, "/_nicegui_ws/socket.io/", "", LOCAL, "websocket")[0] == 1008
    assert app.calls == 0


def test_with_the_token_the_app_answers_and_forbids_framing(door: Door, app: CountingApp) -> None:
    for headers in (WITH_TOKEN, {**LOCAL, "cookie": f"other=1; {COOKIE}={TOKEN}"}):
        status, answer, body = call(door, headers=headers)
        assert (status, body) == (200, b"the page")
        assert answer["x-frame-options"] == "DENY"
        assert answer["content-security-policy"] == "frame-ancestors 'none'"
    assert call(door, "/_nicegui_ws/socket.io/", "", WITH_TOKEN, "websocket")[0] == 101
    assert app.calls == 3


def test_a_foreign_host_is_refused_even_with_the_token(door: Door, app: CountingApp) -> None:
    for host in ("evil.example", "evil.example:8470", "127.0.0.1.evil.example", "localhost.",
                 "", "127.0.0.1:80:80", "[::1", "10.0.0.5"):  # fmt: skip
        assert call(door, headers={**WITH_TOKEN, "host": host})[0] == 403, host
    for host in ("127.0.0.1", "127.0.0.1:8470", "LOCALHOST:8470", "[::1]:8470", "lab-pc.local"):
        assert call(door, headers={**WITH_TOKEN, "host": host})[0] == 200, host
    assert app.calls == 5


def test_a_foreign_origin_is_refused_even_with_the_token(door: Door, app: CountingApp) -> None:
    socket_io = "/_nicegui_ws/socket.io/"
    for origin in ("http://evil.example", "http://127.0.0.1:9999", "null",
                   "https://127.0.0.1:8470", "http://localhost:8470"):  # fmt: skip
        headers = {**WITH_TOKEN, "origin": origin}
        assert call(door, socket_io, "EIO=4&transport=polling", headers)[0] == 403, origin
        assert call(door, socket_io, "", headers, "websocket")[0] == 1008, origin
    own = {**WITH_TOKEN, "origin": f"http://127.0.0.1:{PORT}"}
    assert call(door, socket_io, "", own, "websocket")[0] == 101
    assert app.calls == 1


def test_what_another_page_embeds_is_refused(door: Door, app: CountingApp) -> None:
    """Fetch Metadata (w3c.github.io/webappsec-fetch-metadata): `Sec-Fetch-Site` says where a
    request comes from, `Mode`/`Dest` what for. Another port on 127.0.0.1 is `same-site`."""
    cookie = {**LOCAL, "cookie": f"{COOKIE}={TOKEN}"}
    for site, mode, dest in (("same-site", "no-cors", "image"), ("cross-site", "no-cors", "image"),
                             ("same-site", "navigate", "iframe"), ("same-site", "cors", "empty"),
                             ("same-site", "no-cors", "script")):  # fmt: skip
        headers = {**cookie, "sec-fetch-site": site, "sec-fetch-mode": mode, "sec-fetch-dest": dest}
        assert call(door, headers=headers)[0] == 403, (site, mode, dest)
    assert app.calls == 0
    for site, mode, dest in (("same-origin", "no-cors", "image"), ("none", "navigate", "document"),
                             ("same-site", "navigate", "document")):  # fmt: skip
        headers = {**cookie, "sec-fetch-site": site, "sec-fetch-mode": mode, "sec-fetch-dest": dest}
        assert call(door, headers=headers)[0] == 200, (site, mode, dest)
    assert app.calls == 3


def test_the_token_in_a_page_url_becomes_a_strict_cookie(door: Door, app: CountingApp) -> None:
    status, answer, _ = call(door, "/", f"token={TOKEN}&tab=config", LOCAL)
    assert status == 303 and answer["location"] == "/?tab=config"  # the token leaves the URL
    assert answer["set-cookie"] == f"{COOKIE}={TOKEN}; Path=/; HttpOnly; SameSite=Strict"
    # came from another site (the file:// page the launcher opens): a page of its own refreshes
    cross = {**LOCAL, "sec-fetch-site": "cross-site", "sec-fetch-mode": "navigate",
             "sec-fetch-dest": "document"}  # fmt: skip
    status, answer, body = call(door, "/", f"token={TOKEN}", cross)
    assert status == 200 and "HttpOnly; SameSite=Strict" in answer["set-cookie"]
    assert b'content="0;url=/"' in body and TOKEN.encode() not in body
    # never a redirect to another site, however the path is spelled
    for path in ("//evil.example", "/\\evil.example", "///evil.example/x"):
        location = call(door, path, f"token={TOKEN}", LOCAL)[1]["location"]
        assert location.startswith("/") and not location.startswith("//"), location
        assert "\\" not in location
    assert app.calls == 0  # none of these built a page


def test_a_script_shows_the_token_in_the_query_of_an_app_path(door: Door) -> None:
    status, answer, _ = call(door, "/_nicegui_ws/socket.io/", f"token={TOKEN}&EIO=4", LOCAL)
    assert status == 200 and "set-cookie" not in answer


LOOPBACK_HOST = re.compile(r"(127\.0\.0\.1|localhost|\[::1\])(?::([0-9]{1,5}))?", re.IGNORECASE)


@given(st.text(max_size=40))
@example("LocalHost:65535")
@example("localhost:65536")
@example("[::1]")
def test_any_host_header_is_answered_and_only_this_machines_names_pass(header: str) -> None:
    # RFC 9110 §7.2: Host is `host [":" port]`, an IPv6 address in brackets, names
    # case-insensitive (RFC 4343), a port up to 65535 (RFC 793); bound to 127.0.0.1 the
    # launcher's names are loopback's.
    door = Door(CountingApp(), TOKEN, HostPolicy("127.0.0.1"), COOKIE)
    status = call(door, headers={"host": header, "authorization": f"Bearer {TOKEN}"})[0]
    named = LOOPBACK_HOST.fullmatch(header)
    assert status == (200 if named and int(named[2] or 0) <= 65535 else 403), header


def test_bound_to_every_interface_the_address_it_was_reached_on_is_a_host() -> None:
    # DNS rebinding needs a name of the attacker's: the literal address a colleague on the lab
    # network typed, the one the connection arrived on, cannot be rebound. Another address
    # or a name is not this launcher's.
    door = Door(CountingApp(), TOKEN, HostPolicy("0.0.0.0"), COOKIE)
    bearer = {"authorization": f"Bearer {TOKEN}"}
    for host, reached_on, status in (("192.168.1.20:8470", "192.168.1.20", 200),
                                     ("[fe80::1]:8470", "fe80::1", 200),
                                     ("10.0.0.5:8470", "192.168.1.20", 403),
                                     ("evil.example:8470", "192.168.1.20", 403)):  # fmt: skip
        answer = call(door, headers={**bearer, "host": host}, server=(reached_on, PORT))
        assert answer[0] == status, host
